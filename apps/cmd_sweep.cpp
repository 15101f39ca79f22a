// `ctr sweep`: rotate one tube through a range (and back), carrying the equilibrium branch and hysteresis state.
#include <cmath>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "ctr/model/friction.hpp"
#include "html_report.hpp"
#include "output.hpp"

namespace ctr::cli {

void registerSweep(CLI::App& app, Action& action) {
  struct Opts {
    std::string robot, csv, from, to, step, html;
    int tube = 2;
    bool both = false;
    ConfigOptions config;
    FrictionCli friction;
    LoadsCli loads;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* sub = app.add_subcommand("sweep", "Rotate one tube through a range, warm-starting each step");
  sub->add_option("--robot", o->robot, "Robot description YAML")->required();
  sub->add_option("--tube", o->tube, "Tube to rotate (1 = outermost)")->required();
  sub->add_option("--from", o->from, "Start angle (rad, or e.g. 0deg)")->required();
  sub->add_option("--to", o->to, "End angle (rad, or e.g. 360deg)")->required();
  sub->add_option("--step", o->step, "Angle step (rad, or e.g. 10deg)")->required();
  sub->add_flag("--both-directions", o->both, "Sweep back to the start afterwards");
  sub->add_option("--csv", o->csv, "Write the rows to FILE, or to standard output with - (the default)")
      ->type_name("FILE|-");
  sub->add_option("--html", o->html, "Self-contained HTML plots to write (twist, tip, friction band, stability)")
      ->type_name("FILE");
  o->config.add(sub);
  o->friction.add(sub);
  o->loads.add(sub);
  sub->callback([o, &action]() {
    action = [o]() {
      requireHtmlReports(o->html);
      checkOutputTarget("--csv", o->csv, {{"--robot", o->robot}});
      checkOutputPath("--html", o->html, {{"--robot", o->robot}, {"--csv", o->csv}});
      const Robot robot = o->loads.apply(o->friction.apply(io::loadRobot(o->robot)));
      const int n = robot.size();
      if (o->tube < 1 || o->tube > n)
        throw UsageError("--tube: " + std::to_string(o->tube) + " is not a tube of robot '" + robot.name() + "' (1.." +
                         std::to_string(n) + ")");
      const double a0 = parseNumber(o->from, "--from", true), a1 = parseNumber(o->to, "--to", true);
      const double st = std::abs(parseNumber(o->step, "--step", true));
      if (!(st > 0.0)) throw UsageError("--step: must be non-zero");
      const int count = static_cast<int>(std::floor(std::abs(a1 - a0) / st + 1e-9));
      if (count > 1000000) throw UsageError("--step: too many steps (" + std::to_string(count) + ")");
      const double sgn = a1 >= a0 ? 1.0 : -1.0;
      std::vector<double> angles;
      for (int k = 0; k <= count; ++k) angles.push_back(a0 + sgn * st * k);
      if (std::abs(angles.back() - a1) > 1e-12) angles.push_back(a1);
      std::vector<int> dirs(angles.size(), static_cast<int>(sgn));
      if (o->both) {
        for (int k = static_cast<int>(angles.size()) - 2; k >= 0; --k) {
          angles.push_back(angles[static_cast<std::size_t>(k)]);
          dirs.push_back(-static_cast<int>(sgn));
        }
      }
      const int K = o->tube - 1;
      Configuration q = o->config.resolve(robot, K, angles[0]);  // projected within the tolerance, else exit 2

      Workspace ws;
      const FrictionOptions fo = o->friction.options();
      std::ostringstream csv;
      for (int i = 1; i <= n; ++i) csv << "alpha_" << i << ',';
      for (int i = 1; i <= n; ++i) csv << "beta_" << i << ',';
      for (int i = 2; i <= n; ++i) csv << "twist_" << i << ',';
      csv << "tip_x,tip_y,tip_z,tip_tx,tip_ty,tip_tz,direction,stable,converged,snapped\n";
      StepResult cur = initialState(robot, q, ws, fo);
      int failures = 0;
#ifdef CTR_WITH_REPORTS
      reports::SweepPlot plot;
      plot.robot = robot.name();
      plot.tube = o->tube;
      plot.tubes = n;
      plot.boundary_friction = robot.friction().boundary;
      plot.distributed_friction = robot.friction().distributed;
      plot.friction_mode = o->friction.mode;
#endif
      for (std::size_t k = 0; k < angles.size(); ++k) {
        if (k > 0) {
          q.alpha[K] = angles[k];
          if (cur.state.valid) {
            cur = step(robot, cur.state, q, ws, fo);
          } else {
            cur = initialState(robot, q, ws, fo);
          }
        }
        const Solution& s = cur.solution;
        if (!s.converged()) ++failures;
        for (int i = 0; i < n; ++i) csv << num(q.alpha[i]) << ',';
        for (int i = 0; i < n; ++i) csv << num(q.beta[i]) << ',';
        const bool ok = s.converged();
        for (int i = 0; i + 1 < n; ++i) csv << (ok ? num(s.twist[i]) : "") << ',';
        const Eigen::Vector3d t = s.tipTangent();
        for (int d = 0; d < 3; ++d) csv << (ok ? num(s.tip_position[d]) : "") << ',';
        for (int d = 0; d < 3; ++d) csv << (ok ? num(t[d]) : "") << ',';
        csv << dirs[k] << ',' << (s.summary.stable ? 1 : 0) << ',' << (ok ? 1 : 0) << ','
            << (cur.summary.snapped ? 1 : 0) << '\n';
#ifdef CTR_WITH_REPORTS
        if (!o->html.empty()) {
          reports::SweepRow row;
          row.angle = angles[k];
          row.direction = dirs[k];
          row.converged = ok;
          row.stable = s.summary.stable;
          row.snapped = cur.summary.snapped;
          row.stability = s.summary.stability;
          if (ok) row.twist.assign(s.twist.data(), s.twist.data() + s.twist.size());
          for (int d = 0; d < 3; ++d) row.tip[static_cast<std::size_t>(d)] = s.tip_position[d];
          plot.rows.push_back(row);
        }
#endif
      }
      if (o->csv.empty() || o->csv == kStandardOutput) {
        std::cout << csv.str();
      } else {
        io::writeFileAtomic(o->csv, csv.str());
        std::cerr << "wrote " << angles.size() << " rows to " << o->csv << "\n";
      }
#ifdef CTR_WITH_REPORTS
      if (!o->html.empty()) {
        // Friction band at up to 73 angles of the first pass (every equilibrium reachable under some history).
        if (robot.friction().boundary > 0) {
          const std::size_t first = o->both ? (angles.size() + 1) / 2 : angles.size();
          const std::size_t every = std::max<std::size_t>(1, (first + 71) / 72);
          Configuration qb = o->config.resolve(robot, K, angles[0]);
          std::vector<std::size_t> picks;
          for (std::size_t k = 0; k < first; k += every) picks.push_back(k);
          if (picks.back() + 1 != first) picks.push_back(first - 1);
          for (std::size_t k : picks) {
            qb.alpha[K] = angles[k];
            const FrictionBand fb = frictionBand(robot, qb, ws);
            if (fb.converged) {
              reports::SweepBand b;
              b.angle = angles[k];
              b.twist_min.assign(fb.twist_min.data(), fb.twist_min.data() + fb.twist_min.size());
              b.twist_max.assign(fb.twist_max.data(), fb.twist_max.data() + fb.twist_max.size());
              b.tip_spread = fb.tip_spread;
              plot.band.push_back(b);
            }
          }
        }
        const std::string title = "Sweep of tube " + std::to_string(o->tube) + ": " + robot.name();
        reports::writeHtml(o->html, reports::sweepHtml(plot, title));
        std::cerr << "wrote " << o->html << "\n";
      }
#endif
      if (failures) {
        std::cerr << "error: " << failures << " of " << angles.size()
                  << " steps did not converge (their measurement cells are empty)\n";
        return static_cast<int>(kRuntimeFailure);
      }
      return static_cast<int>(kOk);
    };
  });
}

}  // namespace ctr::cli
