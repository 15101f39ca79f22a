// Shared helpers of the `ctr` command: exit codes, number lists with units, configuration options, output files.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

#include "ctr/io/input_error.hpp"
#include "ctr/model/configuration.hpp"
#include "ctr/model/robot.hpp"

namespace ctr::cli {

/// Exit codes of every subcommand.
enum Exit : int { kOk = 0, kRuntimeFailure = 1, kUsage = 2 };

/// The action a subcommand runs after parsing; returns the exit code.
using Action = std::function<int()>;

/// Usage error (bad option value): exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Parses one number; an angle accepts a `deg` suffix (`90deg`). `what` names the option in errors.
double parseNumber(const std::string& text, const std::string& what, bool angle);
/// Parses "a,b,c" (angles with optional `deg` suffix per item).
std::vector<double> parseList(const std::string& text, const std::string& what, bool angle);

/// Options --alpha/--beta shared by fk, sweep, env check (--from-alpha/--from-beta with the prefix "from-": ik).
struct ConfigOptions {
  std::string alpha, beta;
  std::string prefix;  ///< Of the option names (set by add).
  void add(CLI::App* app, const std::string& option_prefix = "");
  /// Whether --alpha or --beta was given.
  bool given() const { return !alpha.empty() || !beta.empty(); }
  /// Configuration for the robot: missing alpha -> zeros; missing beta -> -straight_length of each tube, clamped
  /// to the nesting rules. The rotation of `swept_tube` (0-based, if >= 0; `ctr sweep`) is `swept_angle` (--from).
  /// Projected onto the admissible set when it violates it by at most kAdmissibilityTolerance (rounded values,
  /// docs/formats.md "Admissibility tolerance"). Throws UsageError for wrong counts and for larger violations
  /// (naming the option and the constraint).
  Configuration resolve(const Robot& robot, int swept_tube = -1, double swept_angle = 0.0) const;
};

/// argv with negative-number values joined to their option ("--beta -0.01,-0.02" -> "--beta=-0.01,-0.02").
std::vector<std::string> normalizeArguments(int argc, char** argv);

/// Checks an output path before any work is done (exit code 2 instead of a late failure or a clobbered input):
/// not empty, not an existing directory, its folder exists, and it is none of the `inputs` (option, path) pairs.
/// Empty `path` (output not requested) is accepted. `option` names the output option in the message.
void checkOutputPath(const std::string& option, const std::string& path,
                     const std::vector<std::pair<std::string, std::string>>& inputs = {});

/// The target of `--json -` and `--csv -`: standard output.
inline const std::string kStandardOutput = "-";

/// @brief `--json [FILE|-]`, the same in every subcommand: write `what` as JSON to FILE, or to standard output with
/// `-` or no value.
CLI::Option* addJsonOption(CLI::App* sub, std::string& target, const std::string& what);

/// @brief checkOutputPath for a target that may be standard output ("-": always accepted).
void checkOutputTarget(const std::string& option, const std::string& target,
                       const std::vector<std::pair<std::string, std::string>>& inputs = {});

/// @brief Writes `text` to a target: standard output for "-", else the file (atomically); nothing for "".
void writeOutput(const std::string& target, const std::string& text);

/// @brief CLI11 check: a finite number > 0 (CLI::PositiveNumber lets nan and inf through).
CLI::Validator finitePositive();
/// @brief CLI11 check: a finite number >= 0.
CLI::Validator finiteNonNegative();
/// @brief CLI11 check: a branch rule parseBranchRule accepts (its message names the valid ones).
CLI::Validator branchRuleValidator();

}  // namespace ctr::cli

#include "ctr/model/friction.hpp"

namespace ctr::cli {

/// Options --tip-force, --tip-moment, --gravity ("x,y,z" in the base frame; N, N m, m/s^2). Each given option
/// replaces that entry of the robot's `loads:` block (docs/formats.md); the others are kept.
struct LoadsCli {
  std::string tip_force, tip_moment, gravity;
  void add(CLI::App* app);
  /// The robot with the loads applied. Throws UsageError for a value that is not three finite numbers.
  Robot apply(const Robot& robot) const;
};

/// Options --boundary-friction, --distributed-friction, --friction-mode (override the robot's friction block).
struct FrictionCli {
  double boundary = -1.0, distributed = -1.0;
  std::string mode = "stick-slip";
  void add(CLI::App* app);
  Robot apply(const Robot& robot) const;
  FrictionOptions options() const;
};

}  // namespace ctr::cli

#ifdef CTR_WITH_PLANNER
#include <stdexcept>

#include "ctr/campaign/campaign.hpp"

namespace ctr::cli {

/// `--shard I/N` (ctr bench, ctr design): throws UsageError naming --shard when it is not I/N with 0 <= I < N.
inline campaign::Shard parseShardOption(const std::string& text) {
  try {
    return campaign::parseShard(text);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--shard: ") + e.what());
  }
}

}  // namespace ctr::cli
#endif
