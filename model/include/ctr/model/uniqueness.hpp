/// @file uniqueness.hpp
/// @brief A certificate that a configuration has exactly one equilibrium, and that it is stable, whatever contact
/// torques a friction history has stored in it (docs/friction.md, "One equilibrium per torque").
///
/// The torsion-only model (Lock & Dupont 2011 §II.A) is the stationary point of the energy
///   E[theta] = sum_i int 1/2 kt_i theta_i'^2 ds - sum_{i<j} int b_ij(s) cos(theta_i - theta_j) ds,
///   b_ij = kb_i kb_j kappa_i kappa_j / K (K: the bending stiffness of the tubes present at s),
/// with theta_i fixed at tube i's proximal end (s = beta_i, where its rotation is imposed). A contact torque tau at a
/// site adds the linear term -tau (theta_inner - theta_outer)(s_site), which leaves the second variation unchanged:
///   d2E[eta] = sum_i int kt_i eta_i'^2 + sum_{i<j} int b_ij cos(theta_i - theta_j) (eta_i - eta_j)^2
///           >= Q[eta] = sum_i int kt_i eta_i'^2 - sum_{i<j} int |b_ij| (eta_i - eta_j)^2.
/// If Q is positive definite, E is strictly convex for every rotation and every set of contact torques, so each
/// torque vector has exactly one equilibrium, and it is stable: no history of stick and slip can put the robot on
/// another branch at the same torques. Q depends on the translations only. For two tubes overlapping over L, both
/// curved, without transmission lengths, Q > 0 is the classic bound L^2 |b| (1/kt_1 + 1/kt_2) < pi^2 / 4.
///
/// Q is discretised by linear finite elements (one element on each piece without coupling, where linear twist is
/// exact; elements of at most `max_element` where tubes couple). The discrete quotient of the coupling over the
/// torsional energy is a Rayleigh-Ritz lower bound of the continuous one, too small by O(h^2): the certificate asks
/// it to stay below 1 - margin.
#pragma once

#include "ctr/model/configuration.hpp"
#include "ctr/model/friction.hpp"
#include "ctr/model/robot.hpp"

namespace ctr {

/// @brief Options of uniquenessCertificate().
struct UniquenessOptions {
  double max_element = 4e-3;  ///< Longest finite element where tubes couple (m).
  int min_elements = 4;       ///< Elements on each coupled piece at least.
  /// The discrete interaction must stay below 1 - margin (covers the discretisation error, O(h^2)).
  double margin = 0.02;
  /// Around a friction band: the range of each pair's relative angle spanned by the band's shapes is widened by this
  /// much (rad) on either side (it covers the angles between the recorded nodes).
  double angle_margin = 0.25;
  /// Also compute UniquenessCertificate::interaction (a bisection of Cholesky factorisations); the certificate alone
  /// needs one.
  bool measure = false;
};

/// @brief Why a configuration is or is not certified.
enum class UniquenessStatus {
  Certified,     ///< Q is positive definite: one equilibrium, stable, for every history's torques.
  Interacting,   ///< The tubes' bending interaction can exceed their torsional stiffness: not certified.
  Loaded,        ///< External loads: the certificate covers the torsion-only model only.
  Inadmissible,  ///< The configuration is not admissible (checkAdmissible).
};

/// @brief "certified", "interacting", "loaded", "inadmissible".
const char* toString(UniquenessStatus s);

/// @brief Result of uniquenessCertificate().
struct UniquenessCertificate {
  UniquenessStatus status = UniquenessStatus::Inadmissible;
  /// With UniquenessOptions::measure: the largest ratio of the coupling term over the torsional energy of any twist
  /// perturbation (discrete; < 1 - margin is certified). NaN when not measured.
  double interaction = 0.0;
  int unknowns = 0;  ///< Finite-element unknowns (twist perturbations at the nodes).
  bool certified() const { return status == UniquenessStatus::Certified; }
};

/// @brief The certificate at q for every rotation: cos >= -1 in Q (the translations alone decide). The robot's drives
/// are not applied: q is in joint space.
UniquenessCertificate uniquenessCertificate(const Robot& robot, const Configuration& q,
                                            const UniquenessOptions& options = {});

/// @brief The certificate around a friction band (frictionBand at one configuration, its shapes recorded with the
/// tubes' angles): Q with cos bounded over the relative angles the band's shapes span, widened by
/// UniquenessOptions::angle_margin. Certified: the energy is strictly convex over the set R of twist fields whose
/// relative angles stay in those ranges, so every torque vector has at most one equilibrium in R. If every equilibrium
/// a history can put in the box lies in the band's hull (the band's vertex assumption, docs/planning.md), a robot in
/// R cannot leave it without a snap and no history reaches another branch at the same torques. Throws
/// std::invalid_argument when the band has no shapes or its shapes carry no tube angles.
UniquenessCertificate uniquenessCertificate(const Robot& robot, const FrictionBand& band,
                                            const UniquenessOptions& options = {});

}  // namespace ctr
