// `--html` support of the ctr subcommands: whether this build has the HTML reports (CTR_BUILD_REPORTS).
#pragma once

#include "cli_common.hpp"

#ifdef CTR_WITH_REPORTS
#include "ctr/reports/reports.hpp"
#endif

namespace ctr::cli {

/// The message of a build without the HTML reports, for `what` ("--html", "view").
inline std::string htmlReportsMissing(const std::string& what) {
  return what +
         ": this ctr was built without HTML reports (configured with -DCTR_BUILD_REPORTS=OFF); "
         "run scripts/install-deps.sh (Node.js, npm) and rebuild with -DCTR_BUILD_REPORTS=ON";
}

/// Throws a UsageError (exit 2) before any work when `--html` is given but the reports were not built.
inline void requireHtmlReports(const std::string& html) {
#ifndef CTR_WITH_REPORTS
  if (!html.empty()) throw UsageError(htmlReportsMissing("--html"));
#else
  (void)html;
#endif
}

}  // namespace ctr::cli

#if defined(CTR_WITH_REPORTS) && defined(CTR_WITH_PLANNER)
#include "ctr/planner/query.hpp"

namespace ctr::cli {

/// The goal of a query as shown by the planning viewer (none without a tip goal).
inline std::optional<reports::ViewGoal> viewGoal(const planner::Query& q) {
  if (!q.tip_goal) return std::nullopt;
  reports::ViewGoal g;
  for (int d = 0; d < 3; ++d) g.position[static_cast<std::size_t>(d)] = q.tip_goal->position[d];
  g.tolerance = q.tip_goal->tolerance;
  g.name = q.target_name;
  return g;
}

}  // namespace ctr::cli
#endif
