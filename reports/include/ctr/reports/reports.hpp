/// @file reports.hpp
/// @brief Self-contained HTML reports: one file with the bundled scripts and styles (three.js, Chart.js) and the data
/// embedded as JSON; it opens offline and fetches nothing. Kinds: diagnosis, planning viewer, sweep, benchmark
/// campaign, robot design.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "ctr/model/configuration.hpp"
#include "ctr/model/friction.hpp"
#include "ctr/model/robot.hpp"

namespace ctr::io {
struct Recording;
}
namespace ctr::diagnosis {
struct DiagnosisReport;
}
namespace ctr::planner {
class Context;
}

namespace ctr::reports {

/// @brief Report kinds (each has its own bundled script).
enum class ReportKind { Diagnosis, Planning, Sweep, Bench, Design };

/// @brief "diagnosis" / "planning" / "sweep" / "bench" / "design" (the name of the report's script bundle).
const char* toString(ReportKind kind);

/// @brief The complete HTML page of a report: `data_json` (a JSON document) is embedded in a
/// `<script type="application/json" id="ctr-data">`; `title` is HTML-escaped.
std::string renderHtml(ReportKind kind, const std::string& title, const std::string& data_json);

/// @brief One row of a sweep (ctr sweep), in the robot's base frame.
struct SweepRow {
  double angle = 0.0;  ///< Rotation of the swept tube (rad).
  int direction = 1;   ///< +1 / -1.
  bool converged = false, stable = false, snapped = false;
  double stability = 0.0;       ///< det of the torsional stability Jacobian (> 0 stable).
  std::vector<double> twist;    ///< Tip twist of tubes 2..n relative to tube 1 (rad).
  std::array<double, 3> tip{};  ///< Tip position (m).
};

/// @brief Friction band at one angle of a sweep (twist extremes over every reachable history).
struct SweepBand {
  double angle = 0.0;
  std::vector<double> twist_min, twist_max;  ///< rad, tubes 2..n.
  double tip_spread = 0.0;                   ///< m.
};

/// @brief Everything the sweep report shows.
struct SweepPlot {
  std::string robot;  ///< Robot name.
  int tube = 2;       ///< Swept tube (1-based).
  int tubes = 3;      ///< Number of tubes.
  double boundary_friction = 0.0, distributed_friction = 0.0;
  std::string friction_mode;  ///< "stick-slip" / "paper".
  std::vector<SweepRow> rows;
  std::vector<SweepBand> band;  ///< Empty without friction.
};

/// @brief The sweep report as HTML (twist and tip vs angle, both directions, band shaded, stability).
std::string sweepHtml(const SweepPlot& sweep, const std::string& title);

/// @brief The diagnosis report as HTML: located mismatch (binned residuals by direction with the noise band),
/// measured / nominal / fitted curves, candidates with held-out RMSE and BIC, verdict, fitted parameters.
/// Embeds reportToJson() and plotDataJson() unchanged.
std::string diagnosisHtml(const diagnosis::DiagnosisReport& report, const io::Recording& rec, const std::string& title);

/// @brief Options of the planning viewer.
struct PlanningViewOptions {
  std::string title = "ctr planning viewer";
  int max_voxels = 60000;      ///< Surface voxels drawn at most (coarsened beyond).
  int max_shape_points = 48;   ///< Backbone points per waypoint shape.
  int band_waypoints = 120;    ///< Waypoints with a friction band (evenly spaced, every one if fewer; 0 = none).
  int band_shape_points = 16;  ///< Backbone points per ghost shape of a band.
  int band_samples = 0;        ///< FrictionBandOptions::interior_samples.
  double crop_margin = 0.0;    ///< > 0: only voxels within this distance of the path's bounding box (m).
  std::string info_json;       ///< Optional JSON object shown in the side panel (e.g. the plan result).
  /// Hysteresis state the robot arrived with (e.g. the query's start history); without it the replay starts from
  /// a rest state (no friction torque) at the first waypoint.
  std::optional<HysteresisState> start;
};

/// @brief Goal shown in the viewer (world frame).
struct ViewGoal {
  std::array<double, 3> position{};
  double tolerance = 0.0;
  std::string name;
};

/// @brief The planning viewer as HTML: anatomy (surface voxels), per-waypoint robot shapes (tubes with their
/// diameters), tip trajectory, goal, collision flags, and friction bands at some waypoints. Shapes are recomputed by
/// a quasi-static replay of `waypoints` through the robot's friction model (ctx.robot()) from options.start (or a
/// rest state at the first waypoint). Throws std::invalid_argument for an empty path.
std::string planningHtml(const planner::Context& ctx, const std::vector<Configuration>& waypoints,
                         const std::optional<ViewGoal>& goal, const PlanningViewOptions& options = {});

/// @brief The benchmark campaign report as HTML (`ctr bench merge --html`): success rate and replay outcomes per
/// query / mode / planner, time-to-solution distributions. `summary_json` is the merge's summary.json (embedded
/// unchanged).
std::string benchHtml(const std::string& summary_json, const std::string& title);

/// @brief One replayed path of a design report: the clearance along the tip's travel.
struct DesignPathPlot {
  std::string query;               ///< The query's name.
  std::vector<double> tip_travel;  ///< Distance travelled by the tip up to each waypoint (m).
  std::vector<double> clearance;   ///< Distance-field clearance at each waypoint (m); NaN where not computed.
  std::string viewer;              ///< Link to the plan's viewer, relative to the report ("" for none).
};

/// @brief The design report (`ctr design --html`): the designed robot against the query's own, which queries each
/// solves (stage reached, closest tip distance, clearance), the search (score of every candidate) and the clearance
/// along the designed paths, with links to their viewers. `result_json`: the run's result.json (embedded unchanged).
std::string designHtml(const std::string& result_json, const std::vector<DesignPathPlot>& paths,
                       const std::string& title);

/// @brief Writes `html` to `path` atomically (no partial file on failure).
void writeHtml(const std::string& path, const std::string& html);

}  // namespace ctr::reports
