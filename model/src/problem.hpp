// Internal: the shooting problem of a configuration: segments between discontinuities, breakpoints with their events
// and the active contacts (shared by the torsion-only, loaded and distributed-friction solvers).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "ctr/model/kinematics.hpp"

namespace ctr {
namespace detail {

/// Arc lengths closer than this are the same point (breakpoints, tube ends).
constexpr double kSameS = 1e-12;

/// A piece of [0, s_tip] on which the set of present tubes and their precurvatures are constant.
struct Segment {
  double s0 = 0, s1 = 0, h = 0;
  int steps = 1;
  std::vector<char> present;  // tube i present on the segment
  Eigen::VectorXd a;          // (kb_i / kt_i) kappa_i / K for present curved tubes, else 0
  Eigen::VectorXd w;          // kb_i kappa_i for present curved tubes, else 0
  double K = 0;               // sum of kb over present tubes
  int outermost = 0;
};

/// Events at the distal end of a segment.
struct Breakpoint {
  double s = 0;
  std::vector<int> ending;           // tubes whose distal end is here
  std::vector<int> discontinuities;  // tubes whose curved part starts here
  std::vector<int> contacts;         // active contacts here (indices into Problem::contacts)
  bool twist_point = false;          // s = distal end of tube 1 (where twist is measured)
};

/// A contact site with its law and its index among the configuration's contact sites.
struct ActiveContact {
  ContactSite site;
  ContactCondition condition;
  int site_index = 0;
};

/// The shooting problem of a configuration: stiffnesses and precurvatures, segments, breakpoints, active contacts;
/// n tubes, m unknowns (n twist rates and one per contact).
struct Problem {
  int n = 0, m = 0;
  double mu_boundary = 0, s_tip = 0, s_twist = 0;
  Eigen::VectorXd kb, kt, kappa, alpha, beta, end, disc;
  std::vector<Segment> segments;
  std::vector<Breakpoint> breakpoints;
  std::vector<ActiveContact> contacts;
  /// Steps from opt (max_step, max_bending_per_step, bending_limit_per_segment), both lengths scaled by step_factor;
  /// precurvatures scaled by kappa_scale (the homotopy).
  void setup(const Robot& robot, const Configuration& q, const std::vector<ContactCondition>* conditions,
             const KinematicsOptions& opt, double kappa_scale = 1.0, double step_factor = 1.0);
};

}  // namespace detail
}  // namespace ctr
