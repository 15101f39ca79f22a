#include "cli_common.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "ctr/io/file.hpp"
#include "ctr/model/replay.hpp"

namespace ctr::cli {

double parseNumber(const std::string& text0, const std::string& what, bool angle) {
  std::string text = text0;
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) text.erase(text.begin());
  double scale = 1.0;
  if (angle && text.size() > 3 && text.compare(text.size() - 3, 3, "deg") == 0) {
    scale = M_PI / 180.0;
    text.resize(text.size() - 3);
  } else if (angle && text.size() > 3 && text.compare(text.size() - 3, 3, "rad") == 0) {
    text.resize(text.size() - 3);
  }
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || !std::isfinite(v))
    throw UsageError(what + ": '" + text0 + "' is not a finite number" + (angle ? " (rad, or with a deg suffix)" : ""));
  return v * scale;
}

std::vector<double> parseList(const std::string& text, const std::string& what, bool angle) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  int k = 0;
  while (std::getline(ss, item, ',')) {
    ++k;
    out.push_back(parseNumber(item, what + " item " + std::to_string(k), angle));
  }
  if (out.empty()) throw UsageError(what + ": empty list");
  return out;
}

void ConfigOptions::add(CLI::App* app, const std::string& option_prefix) {
  prefix = option_prefix;
  const std::string what = prefix == "from-" ? "Start: tube " : "Tube ";
  app->add_option("--" + prefix + "alpha", alpha, what + "rotations a1,a2,.. (rad, or e.g. 90deg); default 0");
  app->add_option("--" + prefix + "beta", beta,
                  what + "translations b1,b2,.. (m, <= 0); default: straight parts retracted");
}

Configuration ConfigOptions::resolve(const Robot& robot, int swept_tube, double swept_angle) const {
  const int n = robot.size();
  Configuration q = defaultConfiguration(robot);
  const std::string alpha_option = "--" + prefix + "alpha", beta_option = "--" + prefix + "beta";
  if (!alpha.empty()) {
    auto a = parseList(alpha, alpha_option, true);
    if (static_cast<int>(a.size()) != n)
      throw UsageError(alpha_option + ": " + std::to_string(a.size()) + " values given, robot '" + robot.name() +
                       "' has " + std::to_string(n) + " tubes");
    for (int i = 0; i < n; ++i) q.alpha[i] = a[static_cast<std::size_t>(i)];
  }
  if (!beta.empty()) {
    auto b = parseList(beta, beta_option, false);
    if (static_cast<int>(b.size()) != n)
      throw UsageError(beta_option + ": " + std::to_string(b.size()) + " values given, robot '" + robot.name() +
                       "' has " + std::to_string(n) + " tubes");
    for (int i = 0; i < n; ++i) q.beta[i] = b[static_cast<std::size_t>(i)];
  }
  if (swept_tube >= 0 && swept_tube < n) q.alpha[swept_tube] = swept_angle;
  // Values typed or pasted from a log are rounded: violations up to kAdmissibilityTolerance are projected (e.g. an
  // inner tube whose end coincides with the outer tube's end), larger ones are usage errors naming the option.
  const Admissibility adm = projectAdmissible(robot, q);
  if (!adm) {
    const bool rotation = adm.actuator == Admissibility::Actuator::Rotation;
    std::string option = rotation ? alpha_option : beta_option;
    if (rotation && swept_tube >= 0 && adm.tube == swept_tube + 1)
      option = "--from";
    else if ((rotation ? alpha : beta).empty())
      option += " (default: " + std::string(rotation ? "0" : "straight parts retracted") + ")";
    throw UsageError(option + ": configuration is not admissible: " + adm.message);
  }
  return q;
}

std::vector<std::string> normalizeArguments(int argc, char** argv) {
  std::vector<std::string> out;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    const bool is_long_option = a.size() > 2 && a[0] == '-' && a[1] == '-' && a.find('=') == std::string::npos;
    if (is_long_option && i + 1 < argc) {
      const std::string next = argv[i + 1];
      const bool negative_number =
          next.size() > 1 && next[0] == '-' && (std::isdigit(static_cast<unsigned char>(next[1])) || next[1] == '.');
      if (negative_number) {
        out.push_back(a + "=" + next);
        ++i;
        continue;
      }
    }
    out.push_back(a);
  }
  return out;
}

void checkOutputPath(const std::string& option, const std::string& path,
                     const std::vector<std::pair<std::string, std::string>>& inputs) {
  namespace fs = std::filesystem;
  if (path.empty()) return;
  const fs::path p(path);
  std::error_code ec;
  if (fs::is_directory(p, ec)) throw UsageError(option + ": '" + path + "' is a directory, not a file name");
  if (!p.has_filename()) throw UsageError(option + ": '" + path + "' is not a file name (ends with a separator)");
  const fs::path folder = p.has_parent_path() ? p.parent_path() : fs::path(".");
  if (!fs::is_directory(folder, ec))
    throw UsageError(option + ": cannot write '" + path + "': the folder '" + folder.string() + "' does not exist");
  for (const auto& [in_option, in_path] : inputs) {
    if (in_path.empty()) continue;
    const bool same = fs::exists(p, ec) && fs::exists(in_path, ec) ? fs::equivalent(p, in_path, ec)
                                                                     : fs::absolute(p, ec).lexically_normal() ==
                                                                           fs::absolute(in_path, ec).lexically_normal();
    if (same)
      throw UsageError(option + ": '" + path + "' is the input file of " + in_option +
                       "; refusing to overwrite an input (choose another output file)");
  }
}

CLI::Option* addJsonOption(CLI::App* sub, std::string& target, const std::string& what) {
  return sub
      ->add_option("--json", target,
                   "Write " + what + " as JSON to FILE, or to standard output with - or without a value")
      ->expected(0, 1)
      ->default_str(kStandardOutput)
      ->type_name("[FILE|-]");
}

void checkOutputTarget(const std::string& option, const std::string& target,
                       const std::vector<std::pair<std::string, std::string>>& inputs) {
  if (target != kStandardOutput) checkOutputPath(option, target, inputs);
}

void writeOutput(const std::string& target, const std::string& text) {
  if (target.empty()) return;
  if (target == kStandardOutput) {
    std::cout << text << std::flush;
  } else {
    io::writeFileAtomic(target, text);
  }
}

}  // namespace ctr::cli

namespace ctr::cli {

namespace {
CLI::Validator finiteAtLeast(bool strict) {
  return CLI::Validator(
      [strict](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (text.empty() || end != text.c_str() + text.size()) return text + " is not a number";
        if (!std::isfinite(v)) return text + " is not allowed: must be a finite number";
        if (strict && !(v > 0)) return text + " is not allowed: must be > 0";
        if (!strict && v < 0) return text + " is not allowed: must not be negative";
        return std::string();
      },
      strict ? "POSITIVE" : "NONNEGATIVE");
}
}  // namespace

CLI::Validator finitePositive() { return finiteAtLeast(true); }
CLI::Validator finiteNonNegative() { return finiteAtLeast(false); }

CLI::Validator branchRuleValidator() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        try {
          parseBranchRule(text);
        } catch (const std::invalid_argument& e) {
          return e.what();
        }
        return "";
      },
      "path|rest");
}

void FrictionCli::add(CLI::App* app) {
  app->add_option("--boundary-friction", boundary, "Lumped friction coefficient mu' (overrides the robot's)")
      ->check(finiteNonNegative());
  app->add_option("--distributed-friction", distributed,
                  "Distributed Coulomb coefficient mu (overrides the robot's)")
      ->check(finiteNonNegative());
  app->add_option("--friction-mode", mode, "stick-slip (default) or paper (always slipping, eq. 34-35)")
      ->check(CLI::IsMember({toString(FrictionMode::StickSlip), toString(FrictionMode::Paper)}));
}

Robot FrictionCli::apply(const Robot& robot) const {
  FrictionCoefficients f = robot.friction();
  if (boundary >= 0.0) f.boundary = boundary;
  if (distributed >= 0.0) f.distributed = distributed;
  return robot.withFriction(f);
}

void LoadsCli::add(CLI::App* app) {
  app->add_option("--tip-force", tip_force, "Tip force fx,fy,fz (N, base frame; replaces the robot's loads entry)");
  app->add_option("--tip-moment", tip_moment, "Tip moment mx,my,mz (N m, base frame; replaces the robot's)");
  app->add_option("--gravity", gravity,
                  "Gravity gx,gy,gz (m/s^2, base frame; acts on the tubes' linear_density; replaces the robot's)");
}

Robot LoadsCli::apply(const Robot& robot) const {
  Loads l = robot.loads();
  auto vec = [](const std::string& text, const std::string& what) {
    const std::vector<double> v = parseList(text, what, false);
    if (v.size() != 3)
      throw UsageError(what + ": expected three numbers x,y,z (base frame), got " + std::to_string(v.size()));
    for (double x : v)
      if (!std::isfinite(x)) throw UsageError(what + ": values must be finite");
    return Eigen::Vector3d(v[0], v[1], v[2]);
  };
  if (!tip_force.empty()) l.tip_force = vec(tip_force, "--tip-force");
  if (!tip_moment.empty()) l.tip_moment = vec(tip_moment, "--tip-moment");
  if (!gravity.empty()) l.gravity = vec(gravity, "--gravity");
  if (!gravity.empty() && l.gravity.norm() > 0.0 && !robot.hasWeight())
    std::cerr << "warning: --gravity has no effect: no tube of robot '" << robot.name()
              << "' has a linear_density (or density with diameters)\n";
  return robot.withLoads(l);
}

FrictionOptions FrictionCli::options() const {
  FrictionOptions o;
  o.mode = mode == toString(FrictionMode::Paper) ? FrictionMode::Paper : FrictionMode::StickSlip;
  o.kinematics.record_backbone = false;
  return o;
}

}  // namespace ctr::cli
