// Internal: the events at a concentrated moment (tube end or curvature discontinuity), written once for the three
// integrators (torsion-only, loaded, distributed friction): the moment's magnitude, the residual of the friction law
// at a contact site, the point-torque jump of the contact's unknown torque, and the packaging of the contact results.
// Templated on the scalar (double, or the loaded map's dual numbers).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <type_traits>
#include <vector>

#include "dual.hpp"
#include "problem.hpp"

namespace ctr::detail {

/// Bending moment magnitude of tube i just before the end of segment sg, for angles th and the bending part
/// (mbx, mby) of R^T m, the internal moment in the Bishop frame (zero without external loads); with `grad` (double
/// only, load-free) also its gradient w.r.t. th. Tubes that end at the same s are taken in their nesting order (the
/// limit of inner tubes protruding by an infinitesimal length): `ending` lists the tubes ending there, and the outer
/// ones among them are left out. Without this rule the moment, hence the friction bound, jumps when coincident ends
/// separate.
template <class T>
T endMoment(const Problem& P, const Segment& sg, const T* th, int i, const std::vector<int>* ending, const T& mbx,
            const T& mby, Eigen::VectorXd* grad = nullptr) {
  const int n = P.n;
  auto excluded = [&](int j) {
    return ending && j < i && std::find(ending->begin(), ending->end(), j) != ending->end();
  };
  T A = 0.0, B = 0.0;
  T si = 0.0, ci = 0.0;  // sin, cos of th[i]
  bool have_i = false;
  double K = sg.K;
  for (int j = 0; j < n; ++j) {
    if (excluded(j)) {
      if (sg.present[static_cast<std::size_t>(j)]) K -= P.kb[j];
      continue;
    }
    if (sg.w[j] != 0.0) {
      T sj, cj;
      sinCos(th[j], sj, cj);
      A += sg.w[j] * cj;
      B += sg.w[j] * sj;
      if (j == i) {
        si = sj;
        ci = cj;
        have_i = true;
      }
    }
  }
  const double chi_kappa = sg.w[i] != 0.0 ? P.kappa[i] : 0.0;
  if (!have_i) sinCos(th[i], si, ci);
  // v = u_xy of tube i's curvature less its precurvature: u0 - chi kappa_i d(theta_i), d = (-sin, cos).
  const T vx = (mbx - B) / K + chi_kappa * si;
  const T vy = (A + mby) / K - chi_kappa * ci;
  const T nv2 = vx * vx + vy * vy;
  using std::sqrt;
  if constexpr (std::is_same_v<T, double>) {
    if (grad) {
      grad->setZero(n);
      if (nv2 > 0.0) {
        const double nv = sqrt(nv2);
        for (int j = 0; j < n; ++j) {
          if (sg.w[j] == 0.0 || excluded(j)) continue;
          const double ddx = -std::cos(th[j]), ddy = -std::sin(th[j]);  // d'(theta_j)
          double dvx = sg.w[j] / K * ddx, dvy = sg.w[j] / K * ddy;
          if (j == i) {
            dvx -= chi_kappa * ddx;
            dvy -= chi_kappa * ddy;
          }
          (*grad)[j] = P.kb[i] * (vx * dvx + vy * dvy) / nv;
        }
      }
    }
  }
  if (!(value(nv2) > 0.0)) return T(0.0);
  return P.kb[i] * sqrt(nv2);
}

/// |jump of m_j| = k_j kappa_j (K - k_j) / K at tube j's curvature discontinuity, K of the segment that follows it.
inline double discontinuityMoment(const Problem& P, const Segment& next, int j) {
  return std::abs(P.kb[j] * P.kappa[j] * (next.K - P.kb[j]) / next.K);
}

/// |m| of the concentrated moment at a contact site on the distal boundary of segment si (angles th there, bending
/// moment (mbx, mby) as for endMoment), with its gradient w.r.t. th when asked (zero at a discontinuity, whose moment
/// does not depend on the angles).
template <class T>
T siteMoment(const Problem& P, std::size_t si, const T* th, const ContactSite& site, const T& mbx, const T& mby,
             Eigen::VectorXd* grad = nullptr) {
  if (site.kind == MomentKind::TubeEnd)
    return endMoment<T>(P, P.segments[si], th, site.tube, &P.breakpoints[si].ending, mbx, mby, grad);
  if (grad) grad->setZero(P.n);
  return T(discontinuityMoment(P, P.segments[si + 1], site.tube));
}

/// value mu' / k_t,inner of a Torque law: tau = this x |m|.
inline double torqueLawFactor(const Problem& P, const ActiveContact& ac) {
  return ac.condition.value * P.mu_boundary / P.kt[ac.site.inner];
}

/// Residual of the law at a contact for its scaled unknown torque tau (the torque on the inner tube over its k_t),
/// the relative twist theta_inner - theta_outer and the moment |m| at the site: Free tau = 0, Stick relative twist =
/// value, Torque tau = value mu' |m| / k_t,inner.
template <class T>
T contactLawResidual(const Problem& P, const ActiveContact& ac, const T& tau, const T& relative_twist,
                     const T& moment) {
  switch (ac.condition.law) {
    case ContactCondition::Law::Free:
      return tau;
    case ContactCondition::Law::Stick:
      return relative_twist - ac.condition.value;
    case ContactCondition::Law::Torque:
      break;
  }
  return tau - torqueLawFactor(P, ac) * moment;
}

/// Where the point torque of a contact acts: T = k_t,inner tau on the inner tube b, -T on the outer tube a, i.e. per
/// unit tau a change of u_z by -1 (b) and -pa (a), pa = -k_t,b / k_t,a: a jump of u_z, or, for a tube that ends at
/// this breakpoint, a term of its distal condition k_i u_iz(s-) = point torque.
struct ContactJump {
  int a = 0, b = 0;
  double pa = 0.0;
  bool a_ends = false, b_ends = false;
};

inline ContactJump contactJump(const Problem& P, const Breakpoint& bp, const ActiveContact& ac) {
  ContactJump j;
  j.a = ac.site.outer;
  j.b = ac.site.inner;
  j.pa = -P.kt[j.b] / P.kt[j.a];
  j.a_ends = std::find(bp.ending.begin(), bp.ending.end(), j.a) != bp.ending.end();
  j.b_ends = std::find(bp.ending.begin(), bp.ending.end(), j.b) != bp.ending.end();
  return j;
}

/// Applies the point torque of unknown tau: to the distal residual r[i] of a tube ending here, else to its u_z.
template <class T>
void applyContactJump(const ContactJump& j, const T& tau, T* r, T* uz) {
  if (j.a_ends)
    r[j.a] -= j.pa * tau;
  else
    uz[j.a] -= j.pa * tau;
  if (j.b_ends)
    r[j.b] -= tau;
  else
    uz[j.b] -= tau;
}

/// The contact unknowns z[first + c] from the contact results of a solution (warm start), matched by site: torque /
/// k_t,inner. Contacts without a match keep their value.
void contactUnknownsFrom(const Problem& P, const std::vector<ContactResult>& contacts, Eigen::VectorXd& z, int first);

/// The contact results of a solve: relative twist and moment per active contact, torque = k_t,inner x the unknown
/// z[first + c].
std::vector<ContactResult> contactResults(const Problem& P, const std::vector<double>& relative_twist,
                                          const std::vector<double>& moment, const Eigen::VectorXd& z, int first);

}  // namespace ctr::detail
