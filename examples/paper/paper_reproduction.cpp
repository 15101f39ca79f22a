// Reproduces the experiments section of Lock & Dupont 2011 with the ctr model (CSV + SVG into OUTDIR):
//  - Figs. 11-12: frictionless S-curve vs the two stick-slip friction branches, tube pairs A and B;
//  - Fig. 10: Poisson ratio 0.3 vs 0.6 (frictionless, pair B);
//  - Fig. 3: distributed contact force at s = L vs relative base angle (pair B);
//  - Figs. 4-6: distributed friction vs mu at alpha(0) = pi/2;
//  - Table 3 style: tip position / tangent of the friction branches vs the frictionless model at 0, 60, .., 300 deg.
// Usage: paper_reproduction OUTDIR [ROBOT_DIR] [MU]   (ROBOT_DIR defaults to examples/robots, MU to 0.12)
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "ctr/io/robot_yaml.hpp"
#include "ctr/model.hpp"
#include "svg_plot.hpp"

using namespace ctr;
using ctr::examples::Series;

namespace {

constexpr double kDeg = M_PI / 180.0;

Configuration cfg(double a2m_deg) {
  return Configuration(Eigen::Vector2d(0, a2m_deg * kDeg), Eigen::Vector2d(-0.018, -0.018));
}

struct Envelope {
  std::vector<double> angle, frictionless, up, down, paper_up, paper_down;
  std::vector<Solution> free_sol, up_sol, down_sol;
};

Envelope envelope(const Robot& robot, double mu) {
  Envelope e;
  Workspace ws;
  FrictionOptions fo;
  fo.kinematics.record_backbone = false;
  const Robot fr = robot.withFriction({mu, 0.0}), fl = robot.withFriction({0.0, 0.0});
  FrictionOptions paper = fo;
  paper.mode = FrictionMode::Paper;
  StepResult up = initialState(fr, cfg(0), ws, fo), pu = initialState(fr, cfg(0), ws, paper),
             free = initialState(fl, cfg(0), ws, fo);
  for (int k = 0; k <= 36; ++k) {
    if (k) {
      up = step(fr, up.state, cfg(10.0 * k), ws, fo);
      pu = step(fr, pu.state, cfg(10.0 * k), ws, paper);
      free = step(fl, free.state, cfg(10.0 * k), ws, fo);
    }
    e.angle.push_back(10.0 * k);
    e.up.push_back(up.solution.twist[0] / kDeg);
    e.paper_up.push_back(pu.solution.twist[0] / kDeg);
    e.frictionless.push_back(free.solution.twist[0] / kDeg);
    e.up_sol.push_back(up.solution);
    e.free_sol.push_back(free.solution);
  }
  std::vector<double> down(37), pdown(37);
  std::vector<Solution> dsol(37);
  StepResult dn = up, pd = pu;
  for (int k = 36; k >= 0; --k) {
    if (k < 36) {
      dn = step(fr, dn.state, cfg(10.0 * k), ws, fo);
      pd = step(fr, pd.state, cfg(10.0 * k), ws, paper);
    }
    down[static_cast<std::size_t>(k)] = dn.solution.twist[0] / kDeg;
    pdown[static_cast<std::size_t>(k)] = pd.solution.twist[0] / kDeg;
    dsol[static_cast<std::size_t>(k)] = dn.solution;
  }
  e.down = down;
  e.paper_down = pdown;
  e.down_sol = dsol;
  return e;
}

void writeEnvelope(const std::string& dir, const std::string& name, const Envelope& e, double mu) {
  std::ofstream f(dir + "/" + name + ".csv");
  f << "alpha2m_deg,twist_frictionless_deg,twist_friction_increasing_deg,twist_friction_decreasing_deg,"
       "twist_paper_mode_increasing_deg,twist_paper_mode_decreasing_deg\n";
  for (std::size_t k = 0; k < e.angle.size(); ++k)
    f << e.angle[k] << ',' << e.frictionless[k] << ',' << e.up[k] << ',' << e.down[k] << ',' << e.paper_up[k] << ','
      << e.paper_down[k] << '\n';
  char title[160];
  std::snprintf(title, sizeof title, "%s: twist vs motor angle (mu' = %.3g)", name.c_str(), mu);
  ctr::examples::writeSvg(dir + "/" + name + ".svg", title, "motor angle alpha_2m (deg)", "tip twist alpha(L) (deg)",
                          {Series{"frictionless", e.angle, e.frictionless, "#000000"},
                           Series{"friction, increasing", e.angle, e.up, "#d62728", true},
                           Series{"friction, decreasing", e.angle, e.down, "#1f77b4", true}});
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: paper_reproduction OUTDIR [ROBOT_DIR] [MU]\n";
    return 2;
  }
  const std::string out = argv[1];
  const std::string robots = argc > 2 ? argv[2] : std::string(CTR_SOURCE_DIR) + "/examples/robots";
  const double mu = argc > 3 ? std::atof(argv[3]) : 0.12;
  std::filesystem::create_directories(out);
  Robot A = io::loadRobot(robots + "/tube_pair_A.yaml");
  Robot B = io::loadRobot(robots + "/tube_pair_B.yaml");

  // Figs. 11-12.
  const Envelope eA = envelope(A, mu), eB = envelope(B, mu);
  writeEnvelope(out, "fig11_pairA_envelope", eA, mu);
  writeEnvelope(out, "fig12_pairB_envelope", eB, mu);
  std::printf("Envelope width at 180 deg: pair A %.1f deg, pair B %.1f deg (mu' = %.3g)\n",
              eA.down[18] - eA.up[18], eB.down[18] - eB.up[18], mu);

  // Fig. 10: nu = 0.3 vs 0.6 (frictionless, pair B).
  {
    auto withNu = [&](double nu) {
      std::vector<Tube> t = B.tubes();
      for (auto& x : t) {
        x.poisson_ratio = nu;
        x.torsional_stiffness = x.bending_stiffness / (1 + nu);
      }
      return Robot(B.name(), t);
    };
    const Envelope a = envelope(withNu(0.3), 0.0), b = envelope(withNu(0.6), 0.0);
    std::ofstream f(out + "/fig10_poisson.csv");
    f << "alpha2m_deg,twist_nu03_deg,twist_nu06_deg\n";
    for (std::size_t k = 0; k < a.angle.size(); ++k) f << a.angle[k] << ',' << a.up[k] << ',' << b.up[k] << '\n';
    ctr::examples::writeSvg(out + "/fig10_poisson.svg", "Pair B, frictionless: Poisson ratio", "motor angle (deg)",
                            "tip twist (deg)",
                            {Series{"nu = 0.6", b.angle, b.up, "#000000"},
                             Series{"nu = 0.3", a.angle, a.up, "#555555", true}});
  }

  // Fig. 3: distributed force at s = L vs relative base angle alpha(0), frictionless.
  {
    std::ofstream f(out + "/fig3_distributed_force.csv");
    f << "alpha2m_deg,alpha0_deg,force_at_tip_N_per_m\n";
    Series s{"|f(L)|", {}, {}, "#000000"};
    Workspace ws;
    for (int k = 0; k <= 36; ++k) {
      DistributedFrictionOptions o;
      o.mu = 0.0;
      o.direction = {1};
      const DistributedFrictionSolution d = solveDistributedFriction(B, cfg(10.0 * k), ws, o);
      if (!d.solution.converged() || d.samples.empty()) continue;
      const double a0 = (d.solution.theta0[1] - d.solution.theta0[0]) / kDeg;
      f << 10.0 * k << ',' << a0 << ',' << d.samples.back().force << '\n';
      s.x.push_back(a0);
      s.y.push_back(d.samples.back().force);
    }
    ctr::examples::writeSvg(out + "/fig3_distributed_force.svg", "Pair B: distributed force at s = L",
                            "relative rotation at s = 0, alpha(0) (deg)", "|f| (N/m)", {s});
  }

  // Figs. 4-6: distributed friction vs mu at alpha(0) = pi/2 (set through the motor angle giving alpha(0) = 90).
  {
    std::ofstream f(out + "/fig4_distributed_friction_vs_mu.csv");
    f << "mu,force_N_per_m,normal_force_N_per_m,friction_torque_Nm_per_m,integrated_friction_torque_Nm,"
         "base_torque_Nm,tip_twist_deg\n";
    Series sf{"|f|", {}, {}, "#000000"}, sn{"|f_n|", {}, {}, "#888888"}, st{"tau x 1e3", {}, {}, "#d62728", true};
    Workspace ws;
    for (double lg = -2; lg <= 5.0001; lg += 0.5) {
      const double mu_d = std::pow(10.0, lg);
      DistributedFrictionOptions o;
      o.mu = mu_d;
      o.direction = {1};
      const DistributedFrictionSolution d = solveDistributedFriction(B, cfg(90), ws, o);
      if (!d.solution.converged()) continue;
      const auto& t = d.samples.back();
      f << mu_d << ',' << t.force << ',' << t.normal_force << ',' << t.friction_torque << ','
        << d.integrated_friction_torque << ',' << B.tube(1).torsional_stiffness * d.solution.base_twist_rate[1] << ','
        << d.solution.twist[0] / kDeg << '\n';
      sf.x.push_back(lg);
      sf.y.push_back(t.force);
      sn.x.push_back(lg);
      sn.y.push_back(t.normal_force);
      st.x.push_back(lg);
      st.y.push_back(t.friction_torque * 1e3);
    }
    ctr::examples::writeSvg(out + "/fig4_distributed_friction_vs_mu.svg", "Pair B at s = L: distributed friction",
                            "log10(mu)", "N/m and N m/m x 1e3", {sf, sn, st});
  }

  // Table 3 style comparison (model vs model; the paper compares with measurements we do not have).
  {
    std::ofstream f(out + "/table3_tip_comparison.csv");
    f << "pair,alpha2m_deg,direction,tip_x_mm,tip_y_mm,tip_z_mm,frictionless_tip_x_mm,frictionless_tip_y_mm,"
         "frictionless_tip_z_mm,position_difference_mm,tangent_difference_deg\n";
    for (const auto& [name, e] : {std::pair<std::string, const Envelope*>{"A", &eA}, {"B", &eB}}) {
      for (int a = 0; a <= 300; a += 60) {
        const std::size_t k = static_cast<std::size_t>(a / 10);
        for (int dir = 0; dir < 2; ++dir) {
          const Solution& s = dir == 0 ? e->up_sol[k] : e->down_sol[k];
          const Solution& r = e->free_sol[k];
          const double dp = (s.tip_position - r.tip_position).norm() * 1e3;
          const double dt = std::acos(std::clamp(s.tipTangent().dot(r.tipTangent()), -1.0, 1.0)) / kDeg;
          f << name << ',' << a << ',' << (dir == 0 ? "increasing" : "decreasing") << ',' << s.tip_position.x() * 1e3
            << ',' << s.tip_position.y() * 1e3 << ',' << s.tip_position.z() * 1e3 << ',' << r.tip_position.x() * 1e3
            << ',' << r.tip_position.y() * 1e3 << ',' << r.tip_position.z() * 1e3 << ',' << dp << ',' << dt << '\n';
          if (name == "B" && a == 180)
            std::printf("Pair B at 180 deg, %s: tip %.1f mm / tangent %.1f deg from the frictionless model\n",
                        dir == 0 ? "increasing" : "decreasing", dp, dt);
        }
      }
    }
  }
  std::printf("wrote CSV and SVG files to %s\n", out.c_str());
  return 0;
}
