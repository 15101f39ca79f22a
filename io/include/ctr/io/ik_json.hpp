/// @file ik_json.hpp
/// @brief The JSON report of the inverse kinematics (`ctr ik --json`, the Python module's ctr.ik / ctr.ik_path; keys
/// in docs/ik.md).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ctr/model/friction_ik.hpp"
#include "ctr/model/ik.hpp"

namespace ctr::io {

/// @brief Everything `ctr ik` reports: one answer per target, with the friction-blind comparison when friction-aware.
struct IkReport {
  std::string robot;  ///< Robot name.
  bool path = false;  ///< A path of targets (--targets): the path object; else the single answer's object.
  struct Row {
    Configuration q;
    IkSummary summary;
    std::optional<FrictionCost> cost;  ///< Friction-aware answers.
    /// A robot with drives: where the commands q put the tubes (the equilibrium's configuration).
    std::optional<Configuration> joints;
    Row() = default;
    /// `drives`: the robot has drives (hasActuation), so q are commands and the joints are reported beside them.
    explicit Row(const IkResult& r, bool drives = false) : q(r.q), summary(r.summary) {
      if (drives) joints = r.solution.q;
    }
    explicit Row(const FrictionIkResult& r, bool drives = false) : q(r.q), summary(r.summary), cost(r.cost) {
      if (drives) joints = r.step.solution.q;
    }
  };
  std::vector<Row> rows;
  bool with_direction = false;  ///< Some target has a direction: rows carry direction_error.
  /// Friction-aware: mu', how the start state was reached and the start configuration.
  struct Friction {
    double boundary = 0.0;
    std::string history = "rest";
    double approach = 0.5;
    Configuration start;
    int start_rows = 1;  ///< Rows before the first target's command in the commands file (the approach, the start).
  };
  std::optional<Friction> friction;
};

/// @brief The report as JSON text. One answer: reached, status, alpha, beta, tip_error, closest, [direction_error],
/// stable, stability, branch_dependent, iterations, evaluations, starts, message, [friction: {blind_alpha, blind_beta,
/// blind_reached, blind_tip, blind_tip_error, alpha_difference, beta_difference, boundary, history, approach,
/// start_alpha, start_beta, start_rows}], [drives: {joint_alpha, joint_beta, alpha_difference, beta_difference}],
/// robot. A path: reached (all), targets, reached_count, tip_error_max,
/// tip_error_rms, [friction: {boundary, ..., blind_tip_error_max, blind_tip_error_rms}], rows [answers], robot.
/// Non-finite numbers are null. `indent` < 0 gives one line.
std::string ikReportJson(const IkReport& report, int indent = -1);

}  // namespace ctr::io
