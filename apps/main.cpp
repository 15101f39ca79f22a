// The `ctr` command: forward kinematics, sweeps, simulation, environments, diagnosis, planning.
#include <cstdlib>
#include <iostream>

#include "commands.hpp"

int main(int argc, char** argv) {
  using namespace ctr::cli;
  CLI::App app{"ctr -- friction-aware modeling and motion planning of concentric tube robots"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Help for all subcommands");
  Action action;
  registerDemo(app, action);
  registerFk(app, action);
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
#endif
#ifdef CTR_WITH_VIEW
  registerView(app, action);
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
  } catch (const CLI::ParseError& e) {
    // CLI11's PositiveNumber / NonNegativeNumber print the whole double range ("Value 0 not in range 0.000000 to
    // 1797...8.000000"): say plainly what is wrong instead.
    const std::string what = e.what();
    const std::size_t v = what.find("Value "), at = what.find(" not in range 0.000000 to 1797693134862315");
    if (v != std::string::npos && at != std::string::npos && v < at) {
      const std::string value = what.substr(v + 6, at - v - 6);
      const bool zero = std::strtod(value.c_str(), nullptr) == 0.0;
      std::cerr << "error: " << what.substr(0, v) << value << " is not allowed: "
                << (zero ? "must be > 0" : "must not be negative") << "\n";
      return kUsage;
    }
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
