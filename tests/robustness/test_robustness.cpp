// Fast subset of the robustness sweep: zero silent wrong answers, high convergence; sampler uniformity.
#include <gtest/gtest.h>

#include <algorithm>

#include "ctr/io/robot_yaml.hpp"
#include "robustness_sweep.hpp"
#include "stickslip_walks.hpp"

using namespace ctr;

TEST(Robustness, NoSilentWrongAnswersOnExampleRobots) {
  for (const char* name : {"dupont_lab_3tube.yaml", "three_tube_generic.yaml", "tube_pair_B.yaml"}) {
    const Robot r = io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/" + name);
    robustness::Tally cold, warm;
    robustness::sweep(r, 400, 11, cold, warm);
    EXPECT_EQ(cold.silent_wrong + warm.silent_wrong, 0) << name;
    EXPECT_EQ(cold.samples, 400);
    EXPECT_GE(static_cast<double>(cold.converged), 0.99 * cold.samples) << name;
    EXPECT_GE(static_cast<double>(warm.converged), 0.99 * warm.samples) << name;
    for (auto& [k, v] : cold.failure_classes) std::cout << name << " cold: " << k << ": " << v << "\n";
  }
}

TEST(Robustness, StickSlipRandomWalksTerminateKeepBoundsAndReport) {
  // Fast subset of `ctr_robustness --walks 1000` (docs/reliability.md): 20 walks x 200 steps, mu' = 0.12 and 0.3.
  for (const char* name : {"dupont_lab_3tube.yaml", "medmpd_lung.yaml"}) {
    const Robot r = io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/" + name);
    for (double mu : {0.12, 0.3}) {
      robustness::WalkOptions wo;
      wo.walks = std::string(name) == "dupont_lab_3tube.yaml" ? 20 : 6;
      wo.steps = 200;
      wo.seed = 5;
      wo.mu = mu;
      const robustness::WalkTally t = robustness::stickSlipWalks(r, wo);
      for (auto& [k, v] : t.failure_classes) std::cout << name << " mu " << mu << ": " << k << ": " << v << "\n";
      EXPECT_EQ(t.silent_wrong, 0) << name << " mu " << mu;
      EXPECT_EQ(t.steps, wo.walks * wo.steps) << name;  // every walk ran to the end (every step returned)
      EXPECT_GE(static_cast<double>(t.converged), 0.95 * (t.steps - t.inadmissible)) << name << " mu " << mu;
      EXPECT_GT(t.inadmissible, 0);    // inadmissible commands were reported as such
      EXPECT_GT(t.slipping_contacts, 0);  // the walks do exercise slipping
      EXPECT_GT(t.resolved, 0);
      EXPECT_LE(t.max_bound_ratio, 1.0 + 1e-8);
    }
  }
}

TEST(Sampling, TranslationsAreAdmissibleAndUniform) {
  // Independent reference: rejection sampling from the bounding box. Two-sample KS test per coordinate.
  const Robot r = io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/three_tube_generic.yaml");
  const TranslationSampler s(r);
  ASSERT_TRUE(s.feasible());
  std::mt19937_64 rng(3);
  const int N = 4000;
  std::vector<std::vector<double>> a(3), b(3);
  for (int k = 0; k < N; ++k) {
    const Configuration q(Eigen::VectorXd::Zero(3), s.sample(rng));
    ASSERT_TRUE(checkAdmissible(r, q, 1e-12)) << checkAdmissible(r, q).message;
    for (int i = 0; i < 3; ++i) a[i].push_back(q.beta[i]);
  }
  std::uniform_real_distribution<double> U(0, 1);
  long tries = 0;
  while (static_cast<int>(b[0].size()) < N && tries < 50000000) {
    ++tries;
    Eigen::VectorXd beta(3);
    for (int i = 0; i < 3; ++i) beta[i] = s.lower()[i] + (s.upper()[i] - s.lower()[i]) * U(rng);
    const Configuration q(Eigen::VectorXd::Zero(3), beta);
    if (!checkAdmissible(r, q) || beta[2] + r.tube(2).length() < 1e-3) continue;
    for (int i = 0; i < 3; ++i) b[i].push_back(beta[i]);
  }
  ASSERT_EQ(static_cast<int>(b[0].size()), N);
  for (int i = 0; i < 3; ++i) {
    std::sort(a[i].begin(), a[i].end());
    std::sort(b[i].begin(), b[i].end());
    double d = 0;
    std::size_t ia = 0, ib = 0;
    while (ia < a[i].size() && ib < b[i].size()) {
      if (a[i][ia] <= b[i][ib]) {
        ++ia;
      } else {
        ++ib;
      }
      d = std::max(d, std::abs(static_cast<double>(ia) / N - static_cast<double>(ib) / N));
    }
    // KS critical value at alpha = 0.001 for two samples of N: 1.95 sqrt(2/N).
    EXPECT_LT(d, 1.95 * std::sqrt(2.0 / N)) << "beta_" << i + 1;
  }
}
