// Registration of the `ctr` subcommands; each lives in its own cmd_*.cpp.
#pragma once

#include "cli_common.hpp"

namespace ctr::cli {

void registerDemo(CLI::App& app, Action& action);
void registerFk(CLI::App& app, Action& action);
void registerIk(CLI::App& app, Action& action);
void registerSweep(CLI::App& app, Action& action);
void registerSimulate(CLI::App& app, Action& action);
#ifdef CTR_WITH_ENVIRONMENTS
void registerEnv(CLI::App& app, Action& action);
#endif
#ifdef CTR_WITH_DIAGNOSIS
void registerDiagnose(CLI::App& app, Action& action);
void registerRecording(CLI::App& app, Action& action);
#endif
#ifdef CTR_WITH_PLANNER
void registerPlan(CLI::App& app, Action& action);
void registerBench(CLI::App& app, Action& action);
#endif
#ifdef CTR_WITH_DESIGN
void registerDesign(CLI::App& app, Action& action);
#endif
#ifdef CTR_WITH_VIEW
void registerView(CLI::App& app, Action& action);
#endif

}  // namespace ctr::cli
