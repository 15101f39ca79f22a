// ctr_robustness ROBOT.yaml... [--count N] [--seed S]: the full robustness sweep; prints a markdown table.
// ctr_robustness ROBOT.yaml... --walks N [--steps K] [--mu M]... [--seed S]: stick-slip random walks instead.
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <vector>

#include "ctr/io/robot_yaml.hpp"
#include "robustness_sweep.hpp"
#include "stickslip_walks.hpp"

int main(int argc, char** argv) {
  long count = 100000;
  unsigned seed = 1;
  long walks = 0;
  int steps = 200;
  std::vector<double> mus;
  std::vector<std::string> robots;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--count" && i + 1 < argc) {
      count = std::atol(argv[++i]);
    } else if (a == "--walks" && i + 1 < argc) {
      walks = std::atol(argv[++i]);
    } else if (a == "--steps" && i + 1 < argc) {
      steps = std::atoi(argv[++i]);
    } else if (a == "--mu" && i + 1 < argc) {
      mus.push_back(std::atof(argv[++i]));
    } else if (a == "--seed" && i + 1 < argc) {
      seed = static_cast<unsigned>(std::atol(argv[++i]));
    } else {
      robots.push_back(a);
    }
  }
  if (robots.empty()) {
    std::cerr << "usage: ctr_robustness ROBOT.yaml... [--count N] [--seed S]\n"
                 "       ctr_robustness ROBOT.yaml... --walks N [--steps K] [--mu M]... [--seed S]\n";
    return 2;
  }
  using namespace ctr::robustness;
  if (walks > 0) {
    if (mus.empty()) mus = {0.12, 0.3};
    std::cout << walkHeader();
    WalkTally all;
    for (const std::string& path : robots) {
      const ctr::Robot r = ctr::io::loadRobot(path);
      for (double mu : mus) {
        WalkOptions wo;
        wo.walks = walks;
        wo.steps = steps;
        wo.seed = seed;
        wo.mu = mu;
        const WalkTally t = stickSlipWalks(r, wo);
        std::ostringstream name;
        name << r.name() << ", " << mu;
        std::cout << walkReport(name.str(), t) << std::endl;
        for (auto& [k, v] : t.failure_classes) std::cerr << name.str() << ": " << k << ": " << v << "\n";
        all.add(t);
      }
    }
    std::cout << walkReport("all", all) << "\n";
    for (auto& [k, v] : all.failure_classes) std::cerr << "all: " << k << ": " << v << "\n";
    return all.silent_wrong == 0 ? 0 : 1;
  }
  std::cout << "| robot / start | samples | converged+verified | stable | unstable (reported) | not converged "
               "(reported) | silent wrong | Newton iterations mean / max | homotopy used | time per solve (us) |\n"
               "|---|---|---|---|---|---|---|---|---|---|\n";
  Tally all_cold, all_warm;
  for (const std::string& path : robots) {
    const ctr::Robot r = ctr::io::loadRobot(path);
    Tally cold, warm;
    sweep(r, count, seed, cold, warm);
    std::cout << report(r.name() + " cold", cold) << "\n" << report(r.name() + " warm", warm) << "\n";
    for (auto& [k, v] : cold.failure_classes) std::cerr << r.name() << " cold: " << k << ": " << v << "\n";
    for (auto& [k, v] : warm.failure_classes) std::cerr << r.name() << " warm: " << k << ": " << v << "\n";
    all_cold.add(cold);
    all_warm.add(warm);
  }
  std::cout << report("all cold", all_cold) << "\n" << report("all warm", all_warm) << "\n";
  return all_cold.silent_wrong + all_warm.silent_wrong == 0 ? 0 : 1;
}
