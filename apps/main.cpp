// The `ctr` command: forward and inverse kinematics, sweeps, simulation, environments, diagnosis, planning.
#include <cstdlib>
#include <iostream>

#include "commands.hpp"
#include "html_report.hpp"

int main(int argc, char** argv) {
  using namespace ctr::cli;
  CLI::App app{"ctr -- friction-aware modeling and motion planning of concentric tube robots", "ctr"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Help for all subcommands");
  Action action;
  registerDemo(app, action);
  registerFk(app, action);
  registerIk(app, action);
  registerSweep(app, action);
  registerSimulate(app, action);
#ifdef CTR_WITH_ENVIRONMENTS
  registerEnv(app, action);
#endif
#ifdef CTR_WITH_DIAGNOSIS
  registerDiagnose(app, action);
  registerRecording(app, action);
#endif
#ifdef CTR_WITH_PLANNER
  registerPlan(app, action);
  registerBench(app, action);
#endif
#ifdef CTR_WITH_DESIGN
  registerDesign(app, action);
#endif
#ifdef CTR_WITH_VIEW
  registerView(app, action);
#elif defined(CTR_WITH_PLANNER)
  // Without the HTML reports the viewer is not built: say so, as `--html` does, rather than "unknown subcommand".
  CLI::App* view =
      app.add_subcommand("view", "3D viewer of a planned path (not in this build: it needs the HTML reports)");
  view->allow_extras();
  view->callback([&action]() { action = []() -> int { throw UsageError(htmlReportsMissing("view")); }; });
#endif
  std::vector<std::string> args = normalizeArguments(argc, argv);
  if (args.size() > 1 && !args[1].empty() && args[1][0] != '-') {
    try {
      app.get_subcommand(args[1]);
    } catch (const CLI::Error&) {
      std::cerr << "error: unknown subcommand '" << args[1] << "' (run 'ctr --help' for the list)\n";
      return kUsage;
    }
  }
  try {
    std::vector<std::string> rev(args.rbegin(), args.rend() - 1);
    app.parse(rev);
  } catch (const CLI::ValidationError& e) {
    // Our checks (finitePositive, ...) already say plainly what is wrong: "--time: 0 is not allowed: must be > 0".
    std::cerr << "error: " << e.what() << "\n";
    return kUsage;
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kOk : kUsage;
  }
  if (!action) return kOk;
  try {
    return action();
  } catch (const ctr::io::InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kUsage;
  } catch (const UsageError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kUsage;
  } catch (const std::invalid_argument& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kUsage;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kRuntimeFailure;
  }
}
