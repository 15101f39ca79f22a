// Unit tests of the diagnosis building blocks: effects, actuation transforms, registration, import, statistics.
#include <gtest/gtest.h>

#include <cstdio>

#include <random>

#include <algorithm>
#include <cmath>
#include <map>

#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/diagnosis/import.hpp"
#include "ctr/diagnosis/simulate.hpp"
#include "ctr/diagnosis/statistics.hpp"
#include "ctr/io/robot_yaml.hpp"
#include "real_log.hpp"

using namespace ctr;
using namespace ctr::diagnosis;

namespace {
Robot pairB() {
  return io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/tube_pair_B.yaml");
}
// Tube pair B and its default actuation sweep, without time.
struct PairBSweep {
  Robot r = pairB();
  std::vector<Configuration> cmd;
  Eigen::VectorXd time;
  PairBSweep() {
    ActuationOptions a;
    a.dt = 0;
    makeActuation(r, a, cmd, time);
  }
};
}  // namespace

TEST(Effect, ParseAndNames) {
  const Effect e = parseEffect("actuator_backlash:tube=2,width=12deg");
  EXPECT_EQ(e.kind, EffectKind::ActuatorBacklash);
  EXPECT_EQ(e.tube, 2);
  EXPECT_NEAR(e.value, 12 * M_PI / 180, 1e-12);
  EXPECT_EQ(parseEffect("boundary_friction:mu=0.12").value, 0.12);
  EXPECT_THROW(parseEffect("friction:mu=1"), std::invalid_argument);
  EXPECT_THROW(parseEffect("actuator_offset:offset=1"), std::invalid_argument);  // missing tube
  EXPECT_THROW(parseEffect("boundary_friction:nu=1"), std::invalid_argument);
  for (EffectKind k : allEffectKinds()) EXPECT_EQ(parseEffectKind(toString(k)), k);
}

TEST(Effect, AppliesToRobot) {
  const Robot r = pairB();
  const Robot m = applyToRobot(r, {{EffectKind::TorsionalStiffness, 0, 0.3},
                                   {EffectKind::Precurvature, 2, 5.0},
                                   {EffectKind::BoundaryFriction, 0, 0.1}});
  EXPECT_NEAR(m.tube(0).torsional_stiffness, r.tube(0).bending_stiffness / 1.3, 1e-12);
  EXPECT_EQ(m.tube(1).curvature, 5.0);
  EXPECT_EQ(m.friction().boundary, 0.1);
  EXPECT_NEAR(nominalValue(r, EffectKind::TorsionalStiffness, 0), 0.6, 1e-12);
  // A nominal robot's external loads are kept by every effect (they were silently dropped).
  Loads l;
  l.tip_force = Eigen::Vector3d(0.01, 0.0, 0.0);
  const Robot loaded = applyToRobot(r.withLoads(l), {{EffectKind::Precurvature, 2, 5.0}});
  EXPECT_EQ(loaded.loads().tip_force, l.tip_force);
}

TEST(Actuation, PlayOperatorAndLatency) {
  Eigen::VectorXd x(7);
  x << 0, 0.1, 0.2, 0.3, 0.2, 0.1, 0.0;
  const Eigen::VectorXd y = playOperator(x, 0.1);
  EXPECT_NEAR(y[0], 0.0, 1e-12);
  EXPECT_NEAR(y[1], 0.05, 1e-12);
  EXPECT_NEAR(y[3], 0.25, 1e-12);
  EXPECT_NEAR(y[4], 0.25, 1e-12);  // reversal inside the dead band
  EXPECT_NEAR(y[5], 0.15, 1e-12);
  std::vector<Configuration> c;
  Eigen::VectorXd t(4);
  for (int k = 0; k < 4; ++k) {
    c.emplace_back(Eigen::Vector2d(0, 0.1 * k), Eigen::Vector2d(-0.018, -0.018));
    t[k] = 0.5 * k;
  }
  const auto q = transformActuation(c, t, {{EffectKind::SensorLatency, 0, 0.25}, {EffectKind::ActuatorOffset, 2, 1.0}});
  EXPECT_NEAR(q[0].alpha[1], 1.0, 1e-12);
  EXPECT_NEAR(q[2].alpha[1], 1.15, 1e-12);  // t = 1.0 - 0.25 -> alpha 0.15
}

// The diagnosis's drive effects and the robot description's actuation block are one operator (ctr::Drive): a robot
// whose drives carry the fitted values puts its tubes where transformActuation puts the commands, row by row.
TEST(Actuation, DriveEffectsAreTheRobotsDrives) {
  const Robot r = pairB();
  std::vector<Configuration> c;
  for (int k = 0; k < 30; ++k) {
    const double a = 1.5 * std::sin(0.4 * k), b = -0.018 - 0.004 * std::cos(0.3 * k);
    c.emplace_back(Eigen::Vector2d(0.3 * std::cos(0.2 * k), a), Eigen::Vector2d(b, b));
  }
  Effect ratio{EffectKind::DriveRatio, 1, 0.0};
  ratio.coef[0] = 0.03;
  ratio.ref[0] = 0.2;
  Effect periodic{EffectKind::DrivePeriodic, 2, 0.0};
  periodic.coef.head<4>() << 0.01, -0.02, 0.004, 0.0;
  Effect stage{EffectKind::StageError, 2, 0.0};
  stage.coef.head<3>() << 2e-4, -1e-4, 5e-5;
  stage.ref = Eigen::Vector2d(-0.02, 0.004);
  const std::vector<Effect> effects = {{EffectKind::ActuatorBacklash, 2, 0.2},
                                       {EffectKind::ActuatorOffset, 2, -0.07},
                                       {EffectKind::TranslationBacklash, 1, 0.001},
                                       ratio,
                                       periodic,
                                       stage,
                                       {EffectKind::TranslationOffset, 1, -0.0005}};
  const std::vector<Configuration> q = transformActuation(c, Eigen::VectorXd(), effects, &r);
  Tube outer = r.tube(0), inner = r.tube(1);
  outer.rotation_drive.ratio_error = 0.03;
  outer.rotation_drive.ratio_reference = 0.2;
  outer.translation_drive.play = 0.001;
  outer.translation_drive.offset = -0.0005;
  inner.rotation_drive.play = 0.2;
  inner.rotation_drive.offset = -0.07;
  inner.rotation_drive.periodic = {0.01, -0.02, 0.004, 0.0};
  inner.translation_drive.stage = {2e-4, -1e-4, 5e-5};
  inner.translation_drive.stage_reference = -0.02;
  inner.translation_drive.stage_scale = 0.004;
  const Robot driven = r.withTube(0, outer).withTube(1, inner);
  DriveState drives;
  for (std::size_t k = 0; k < c.size(); ++k) {
    const Configuration j = jointsOf(driven, c[k], drives);
    EXPECT_EQ(j.alpha, q[k].alpha) << k;
    EXPECT_EQ(j.beta, q[k].beta) << k;
  }
}

// `--robot-out`: the nominal description with the named effects applied (drives in the actuation blocks), the
// recording's effects and unnamed partial explanations not applied; the written description reads back, says where
// each value came from, and replays the final model's prediction (without the recording's latency) exactly.
TEST(RobotOut, TheDiagnosedRobotReplaysTheFinalModelsPrediction) {
  const Robot r = pairB();
  DiagnosisReport rep;
  rep.verdict = {"boundary_friction", "actuator_backlash", "actuator_offset", "sensor_latency"};
  rep.final_effects = {{EffectKind::BoundaryFriction, 0, 0.1},
                       {EffectKind::ActuatorBacklash, 2, 0.2},
                       {EffectKind::ActuatorOffset, 2, 0.05},
                       {EffectKind::SensorLatency, 0, 0.1},
                       {EffectKind::TorsionalStiffness, 0, 0.4}};
  for (std::size_t k = 0; k < rep.final_effects.size(); ++k) {
    Finding f;
    f.effect = rep.final_effects[k];
    f.accepted = true;
    f.named = k < 4;  // the torsional stiffness is a partial explanation, kept in the fit, not named
    f.round = static_cast<int>(k) + 1;
    rep.findings.push_back(f);
  }
  EffectUncertainty u;
  u.interval95 = {{0.09, 0.11}};
  rep.final_uncertainty["boundary_friction"] = u;
  const Robot out = diagnosedRobot(r, rep);
  EXPECT_EQ(out.friction().boundary, 0.1);
  EXPECT_EQ(out.tube(1).rotation_drive.play, 0.2);
  EXPECT_EQ(out.tube(1).rotation_drive.offset, 0.05);
  EXPECT_TRUE(out.tube(0).rotation_drive.ideal() && out.tube(1).translation_drive.ideal());
  EXPECT_EQ(out.tube(0).torsional_stiffness, r.tube(0).torsional_stiffness) << "a partial explanation is not applied";
  const std::string yaml = diagnosedRobotYaml(r, rep, "rec.csv");
  for (const char* words : {"rec.csv", "[0.09, 0.11]", "tubes[2].actuation.rotation.play", "sensor_latency",
                            "an effect of the recording", "not named"})
    EXPECT_NE(yaml.find(words), std::string::npos) << words << "\n" << yaml;
  const Robot back = io::parseRobot(yaml, "out.yaml");
  EXPECT_EQ(back.friction().boundary, 0.1);
  EXPECT_EQ(back.tube(1).rotation_drive.play, 0.2);
  EXPECT_EQ(back.tube(1).rotation_drive.offset, 0.05);

  std::vector<Configuration> commands;
  for (int k = 0; k < 40; ++k)
    commands.emplace_back(Eigen::Vector2d(0, 1.2 * std::sin(0.25 * k)), Eigen::Vector2d(-0.018, -0.018));
  std::vector<Effect> robot_effects(rep.final_effects.begin(), rep.final_effects.begin() + 3);
  Workspace ws;
  const Prediction p = predict(r, commands, Eigen::VectorXd(), robot_effects, ws);
  const std::vector<ReplayRow> rows = replay(back, commands, ws, PredictOptions{}.replay);
  ASSERT_EQ(rows.size(), commands.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    ASSERT_TRUE(p.ok[k] && rows[k].ok) << k;
    EXPECT_LT(
        (p.tip_position.row(static_cast<Eigen::Index>(k)).transpose() - rows[k].result.solution.tip_position).norm(),
        1e-9)
        << k;
  }
  // A verdict that names nothing applies nothing.
  rep.verdict.clear();
  const Robot none = diagnosedRobot(r, rep);
  EXPECT_FALSE(hasActuation(none));
  EXPECT_EQ(none.friction().boundary, r.friction().boundary);
  EXPECT_NE(diagnosedRobotYaml(r, rep, "rec.csv").find("Nothing applied"), std::string::npos);
}

TEST(Registration, RecoversRigidTransformAndOffset) {
  const Robot r = pairB();
  std::vector<Configuration> cmd;
  Eigen::VectorXd time;
  ActuationOptions a;
  makeActuation(r, a, cmd, time);
  Workspace ws;
  Prediction p = predict(r, cmd, time, {}, ws);
  Registration truth;
  truth.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  truth.translation = Eigen::Vector3d(0.1, -0.2, 0.05);
  truth.tip_offset = 0.01;
  Eigen::MatrixXd P = p.tip_position, T = p.tip_tangent;
  applyRegistration(truth, P, T);
  const Registration est = fitRegistration(p.tip_position, p.tip_tangent, P, T, std::vector<char>(P.rows(), 1));
  EXPECT_LT((est.rotation - truth.rotation).norm(), 1e-6);
  EXPECT_LT((est.translation - truth.translation).norm(), 1e-6);
  EXPECT_NEAR(est.tip_offset, 0.01, 1e-6);
}

TEST(Import, MappingUnwrapAndDupontFormat) {
  auto m = parseColumnMapping("beta_3=7*0.001");
  EXPECT_EQ(m.first, "beta_3");
  EXPECT_EQ(m.second.column, 7);
  EXPECT_DOUBLE_EQ(m.second.scale, 0.001);
  m = parseColumnMapping("tip_tx=11*-1+0.5");
  EXPECT_DOUBLE_EQ(m.second.scale, -1.0);
  EXPECT_DOUBLE_EQ(m.second.offset, 0.5);
  EXPECT_THROW(parseColumnMapping("alpha_1"), std::invalid_argument);
  Eigen::VectorXd a(4);
  a << 3.0, -3.0, -2.9, 3.1;
  unwrapAngles(a);
  EXPECT_NEAR(a[1], 2 * M_PI - 3.0, 1e-12);
  EXPECT_NEAR(a[3], 3.1, 1e-12);
  const std::optional<io::Recording> loaded = test::realLog();
  if (!loaded) GTEST_SKIP() << ctr_test::missingData(test::kRealLogFile);
  const io::Recording& rec = *loaded;
  EXPECT_EQ(rec.rows(), 1307);
  EXPECT_EQ(rec.tubes, 3);
  EXPECT_TRUE(rec.hasTime() && rec.hasTipPosition() && rec.hasTipTangent() && !rec.hasTwist());
  EXPECT_NEAR(rec.commands[0].beta[1], -0.017, 1e-9);
  EXPECT_NEAR(rec.tip_tangent.row(0).norm(), 1.0, 1e-9);
  EXPECT_NEAR(rec.tip_position(0, 2), 0.154601, 1e-9);
  // Unwrapped: no jump larger than pi between consecutive rows.
  for (int k = 1; k < rec.rows(); ++k)
    for (int i = 0; i < 3; ++i) EXPECT_LT(std::abs(rec.commands[k].alpha[i] - rec.commands[k - 1].alpha[i]), M_PI);
  EXPECT_THROW(importTableText("1 2 x\n", "t", dupontLabImportOptions()), io::InputError);
}

TEST(Statistics, TailProbabilities) {
  EXPECT_NEAR(stats::normalSf(1.959964), 0.025, 1e-6);
  EXPECT_NEAR(stats::chiSquareSf(3.841459, 1), 0.05, 1e-6);
  EXPECT_NEAR(stats::chiSquareSf(18.307038, 10), 0.05, 1e-6);
  EXPECT_NEAR(stats::studentSf(2.228139, 10), 0.025, 1e-6);
  Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(20, 0, 1), y = x.array().square();
  EXPECT_NEAR(stats::spearman(x, y).r, 1.0, 1e-12);
  EXPECT_LT(stats::spearman(x, y).p_value, 1e-6);
}

TEST(Statistics, HacIntervalsCoverUnderSerialCorrelation) {
  // y_t = a + b x_t + e_t with a slowly varying regressor and AR(1) errors (rho = 0.8): the independent-residual
  // Gauss-Newton interval of b is far too narrow; the HAC interval must cover b about 95 % of the time.
  std::mt19937 rng(3);
  std::normal_distribution<double> N(0.0, 1.0);
  const int T = 300, reps = 400;
  int cover_hac = 0, cover_naive = 0;
  double sum_sd_hac = 0, sum_b = 0, sum_b2 = 0;
  for (int rep = 0; rep < reps; ++rep) {
    Eigen::MatrixXd J(T, 2);
    Eigen::VectorXd y(T);
    double e = N(rng) / std::sqrt(1 - 0.64), x = N(rng) / std::sqrt(1 - 0.81);
    for (int t = 0; t < T; ++t) {
      e = 0.8 * e + N(rng);
      x = 0.9 * x + N(rng);
      J(t, 0) = 1.0;
      J(t, 1) = x;
      y[t] = 1.0 + 0.5 * x + e;
    }
    const Eigen::Vector2d beta = (J.transpose() * J).ldlt().solve(J.transpose() * y);
    const Eigen::VectorXd r = y - J * beta;
    const stats::HacCovariance h = stats::hacCovariance(J, r, 1);
    const double s2 = r.squaredNorm() / (T - 2);
    const double sd_naive = std::sqrt(s2 * (J.transpose() * J).inverse()(1, 1));
    const double sd_hac = std::sqrt(h.covariance(1, 1));
    cover_hac += std::abs(beta[1] - 0.5) <= 1.96 * sd_hac;
    cover_naive += std::abs(beta[1] - 0.5) <= 1.96 * sd_naive;
    sum_sd_hac += sd_hac;
    sum_b += beta[1];
    sum_b2 += beta[1] * beta[1];
    EXPECT_GT(h.rho, 0.4);
  }
  const double sd_true = std::sqrt(sum_b2 / reps - (sum_b / reps) * (sum_b / reps));
  std::printf("coverage HAC %.3f, naive %.3f; mean HAC sd / empirical sd = %.3f\n", double(cover_hac) / reps,
              double(cover_naive) / reps, sum_sd_hac / reps / sd_true);
  EXPECT_GT(cover_hac, 0.88 * reps);
  EXPECT_LT(cover_naive, 0.80 * reps);
  EXPECT_NEAR(sum_sd_hac / reps / sd_true, 1.0, 0.2);
  // Independent residuals: close to the classical s^2 (J^T J)^-1 (automatic bandwidth stays small).
  Eigen::MatrixXd J(T, 2);
  Eigen::VectorXd r(T);
  for (int t = 0; t < T; ++t) {
    J(t, 0) = 1.0;
    J(t, 1) = N(rng);
    r[t] = N(rng);
  }
  const stats::HacCovariance h = stats::hacCovariance(J, r, 1);
  const double naive = r.squaredNorm() / (T - 2) * (J.transpose() * J).inverse()(1, 1);
  EXPECT_NEAR(h.covariance(1, 1) / naive, 1.0, 0.3);
  EXPECT_LT(std::abs(h.rho), 0.3);
  EXPECT_THROW(stats::hacCovariance(J, r, 7), std::invalid_argument);
}

TEST(Diagnose, NullSweepGivesEmptyVerdictAndJson) {
  const PairBSweep w;
  const Robot& r = w.r;
  SimulationOptions s;
  s.seed = 7;
  const io::Recording rec = simulateRecording(r, w.cmd, w.time, {}, s);
  DiagnoseOptions o;
  o.candidates = {EffectKind::TorsionalStiffness, EffectKind::ActuatorOffset, EffectKind::Precurvature};
  const DiagnosisReport rep = diagnose(r, rec, o);
  EXPECT_TRUE(rep.verdict.empty());
  const std::string js = reportToJson(rep);
  EXPECT_NE(js.find("\"verdict\": []"), std::string::npos);
  EXPECT_NE(js.find("\"findings\""), std::string::npos);
  EXPECT_NE(reportToMarkdown(rep, rec).find("Verdict"), std::string::npos);
  EXPECT_NE(plotDataJson(rep, rec).find("residual_bins"), std::string::npos);
  EXPECT_NEAR(rep.noise.levels().twist, s.twist_sd, 0.4 * s.twist_sd);
}

// The replay tries coarse sub-steps per row and falls back to the fine ones; sub-steps only carry the branch, so
// both must give the same outputs (the stick-slip state at a row's end does not depend on the sub-steps).
TEST(ForwardModel, CoarsePassEqualsFineReplay) {
  struct Case {
    std::string robot;
    ActuationPattern pattern;
    bool translate;
    std::vector<Effect> effects;
    int rows;
  };
  const std::vector<Case> cases = {
      {"tube_pair_B", ActuationPattern::Random, false, {{EffectKind::BoundaryFriction, 0, 0.12}}, 80},
      {"tube_pair_B", ActuationPattern::Sweep, false, {{EffectKind::BoundaryFriction, 0, 0.3}}, 0},
      {"tube_pair_A", ActuationPattern::RandomWalk, false, {{EffectKind::BoundaryFriction, 0, 0.2}}, 80},
      {"dupont_lab_3tube", ActuationPattern::Random, true, {{EffectKind::BoundaryFriction, 0, 0.1}}, 60},
      {"three_tube_generic", ActuationPattern::RandomWalk, true, {{EffectKind::BoundaryFriction, 0, 0.15}}, 60},
      {"tube_pair_B", ActuationPattern::Random, false, {{EffectKind::DistributedFriction, 0, 0.3}}, 12},
      {"tube_pair_B",
       ActuationPattern::Random,
       false,
       {{EffectKind::BoundaryFriction, 0, 0.12}, {EffectKind::DistributedFriction, 0, 0.3}},
       8},
  };
#ifdef CTR_SANITIZED
  const int divide = 4;  // the fine reference replays are slow under ASan
#else
  const int divide = 1;
#endif
  for (const Case& c : cases) {
    const Robot r = io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/" + c.robot + ".yaml");
    ActuationOptions ao;
    ao.pattern = c.pattern;
    ao.rows = c.rows > 0 ? std::max(4, c.rows / divide) : c.rows;
    ao.translate = c.translate;
    ao.seed = 7;
    std::vector<Configuration> cmd;
    Eigen::VectorXd time;
    makeActuation(r, ao, cmd, time);
    Workspace ws;
    PredictOptions coarse, fine;
    fine.replay.coarse_rotation_step = 0.0;
    const Prediction a = predict(r, cmd, time, c.effects, ws, coarse);
    const Prediction b = predict(r, cmd, time, c.effects, ws, fine);
    SCOPED_TRACE(c.robot + " " + toString(c.effects[0].kind));
    // Same rows evaluated (random-order 3-tube rows may be reached through a snap: excluded by both passes, never
    // failed for another reason), identical outputs on them, NaN (not another row's output) on the others.
    ASSERT_EQ(a.ok, b.ok);
    for (int k = 0; k < a.rows(); ++k) {
      if (a.ok[static_cast<std::size_t>(k)]) {
        EXPECT_LT((a.tip_position.row(k) - b.tip_position.row(k)).cwiseAbs().maxCoeff(), 1e-8) << "row " << k;
        EXPECT_LT((a.tip_tangent.row(k) - b.tip_tangent.row(k)).cwiseAbs().maxCoeff(), 1e-8) << "row " << k;
        if (a.twist.cols()) {
          EXPECT_LT((a.twist.row(k) - b.twist.row(k)).cwiseAbs().maxCoeff(), 1e-8) << "row " << k;
        }
      } else {
        EXPECT_EQ(a.message[static_cast<std::size_t>(k)].rfind("snapped", 0), 0u)
            << a.message[static_cast<std::size_t>(k)];
        EXPECT_TRUE(a.tip_position.row(k).array().isNaN().all()) << "row " << k;
      }
    }
    EXPECT_LE(a.failures, a.rows() / 5);
  }
}

// A decimated recording (every k-th row kept, the full-rate log as CommandHistory) is replayed through the joint
// reversals between kept rows: the stick-slip memory set at a reversal that falls between two kept rows is kept.
// Rotation-only moves of a pair with one friction site, so the end state of every move depends only on its end
// points and the reversals: the kept rows must equal the full-rate replay (a straight move between kept rows
// missed the reversal and looked like play: up to the whole friction band).
TEST(ForwardModel, DecimatedReplayPassesTheReversalsBetweenKeptRows) {
  const Robot r = pairB();
  const double deg = M_PI / 180;
  std::vector<Configuration> full;
  std::vector<double> a2;
  for (double a = 0; a <= 100; a += 1) a2.push_back(a);   // up to 100 deg
  for (double a = 99; a >= 37; a -= 1) a2.push_back(a);   // reversal at 100, down to 37
  for (double a = 38; a <= 150; a += 1) a2.push_back(a);  // reversal at 37, up to 150
  Eigen::VectorXd time(static_cast<Eigen::Index>(a2.size()));
  for (std::size_t i = 0; i < a2.size(); ++i) {
    Configuration q = Configuration::zeros(2);
    q.beta << -r.tube(0).straight_length, -r.tube(1).straight_length;
    q.alpha[1] = a2[i] * deg;
    full.push_back(q);
    time[static_cast<Eigen::Index>(i)] = 0.1 * static_cast<double>(i);
  }
  ASSERT_LE(contactSites(r, full[0]).size(), 1u);
  const std::vector<Effect> eff = {{EffectKind::BoundaryFriction, 0, 0.12}};
  Workspace ws;
  PredictOptions po;
  const Prediction ref = predict(r, full, time, eff, ws, po);
  // Keep every 7th row: the reversal rows (100 and 101 + 63 = 164) are not kept.
  CommandHistory h;
  h.commands = full;
  h.time = time;
  std::vector<Configuration> kept;
  Eigen::VectorXd kt((static_cast<Eigen::Index>(full.size()) + 6) / 7);
  for (int i = 0, j = 0; i < static_cast<int>(full.size()); i += 7, ++j) {
    ASSERT_NE(i, 100);
    ASSERT_NE(i, 164);
    h.rows.push_back(i);
    kept.push_back(full[static_cast<std::size_t>(i)]);
    kt[j] = time[i];
  }
  PredictOptions dec = po;
  dec.history = &h;
  const Prediction p = predict(r, kept, kt, eff, ws, dec);
  double worst = 0, straight_worst = 0;
  PredictOptions straight = po;  // the same rows without the history: straight moves between kept rows
  const Prediction s = predict(r, kept, kt, eff, ws, straight);
  for (std::size_t k = 0; k < h.rows.size(); ++k) {
    const int i = h.rows[k];
    ASSERT_TRUE(p.ok[k] && ref.ok[static_cast<std::size_t>(i)]) << "row " << k;
    worst = std::max(worst, std::abs(p.twist(static_cast<Eigen::Index>(k), 0) - ref.twist(i, 0)));
    straight_worst = std::max(straight_worst, std::abs(s.twist(static_cast<Eigen::Index>(k), 0) - ref.twist(i, 0)));
  }
  EXPECT_LT(worst, 1e-8);
  EXPECT_GT(straight_worst, 1e-2);  // the case separates: without the reversals the kept rows are wrong
}

// Found by fuzz_import: a mapping named alpha_<not a number> escaped from importTableText as std::invalid_argument
// (std::stoi) when the tube count is inferred.
TEST(Import, BadAlphaMappingNamesAreInputErrors) {
  for (const char* name : {"alpha_x", "alpha_", "alpha_99999999999", "alpha_1e3"}) {
    SCOPED_TRACE(name);
    ImportOptions o;
    o.columns[name] = {1, 1.0, 0.0};
    o.columns["beta_1"] = {2, 1.0, 0.0};
    o.columns["twist_2"] = {3, 1.0, 0.0};
    EXPECT_THROW(importTableText("1 2 3\n", "t", o), io::InputError);
  }
}

// Found by fuzz_import (UBSan): a column number beyond int (2888888888) was cast to int.
TEST(Import, HugeColumnNumbersAreRejected) {
  EXPECT_THROW(parseColumnMapping("alpha_2=2888888888"), std::invalid_argument);
  EXPECT_THROW(parseColumnMapping("alpha_2=1e300"), std::invalid_argument);
  EXPECT_THROW(parseColumnMapping("alpha_2=0"), std::invalid_argument);
  EXPECT_EQ(parseColumnMapping("alpha_2=1000000").second.column, 1000000);
}

// A description off in several parameters at once, each too far from the truth for any one of them alone to explain
// the recording (the selection, one effect allowed, finds none or one): the remainder is left unexplained unless
// the description is calibrated as a block. The
// calibration recovers every parameter that was off, and backward elimination removes those that were not.
TEST(Calibration, FitsTheDescriptionAsABlockAndKeepsWhatEarnsItsPlace) {
  const PairBSweep w;
  const Robot& r = w.r;
  SimulationOptions s;
  s.seed = 5;
  const double k1 = 0.85 * r.tube(0).curvature, k2 = 1.15 * r.tube(1).curvature, offset = 6 * M_PI / 180;
  const io::Recording rec = simulateRecording(
      r, w.cmd, w.time,
      {{EffectKind::Precurvature, 1, k1}, {EffectKind::Precurvature, 2, k2}, {EffectKind::ActuatorOffset, 2, offset}},
      s);
  DiagnoseOptions o;
  o.candidates = {EffectKind::Precurvature, EffectKind::ActuatorOffset, EffectKind::TorsionalStiffness,
                  EffectKind::BoundaryFriction};
  o.max_effects = 1;
  o.calibrate_description = false;
  const DiagnosisReport plain = diagnose(r, rec, o);
  EXPECT_LE(plain.final_effects.size(), 1u) << plain.summary;
  EXPECT_TRUE(plain.unexplained.present) << plain.summary;
  o.calibrate_description = true;
  const DiagnosisReport rep = diagnose(r, rec, o);
  std::map<std::string, double> got;
  for (const Effect& e : rep.final_effects) got[e.label()] = e.value;
  ASSERT_TRUE(got.count("precurvature[tube 1]")) << rep.summary;
  ASSERT_TRUE(got.count("precurvature[tube 2]")) << rep.summary;
  ASSERT_TRUE(got.count("actuator_offset[tube 2]")) << rep.summary;
  std::printf("calibrated: precurvature %.4f / %.4f (true %.4f / %.4f) 1/m, offset %.2f deg (true 6)\n",
              got["precurvature[tube 1]"], got["precurvature[tube 2]"], k1, k2,
              got["actuator_offset[tube 2]"] * 180 / M_PI);
  EXPECT_NEAR(got["precurvature[tube 1]"] / k1, 1.0, 0.03) << rep.summary;
  EXPECT_NEAR(got["precurvature[tube 2]"] / k2, 1.0, 0.03) << rep.summary;
  EXPECT_NEAR(got["actuator_offset[tube 2]"] / offset, 1.0, 0.1) << rep.summary;
  EXPECT_EQ(got.count("torsional_stiffness"), 0u) << rep.summary;  // not off: removed again
  EXPECT_EQ(got.count("boundary_friction"), 0u) << rep.summary;    // not part of a calibration
  EXPECT_FALSE(rep.unexplained.present) << rep.summary;
  const std::string js = reportToJson(rep);
  EXPECT_NE(js.find("accepted with the calibration of the robot's description"), std::string::npos);
  // --robot-out with --calibrate: the description carries the calibrated values (precurvatures, the drive's offset).
  const Robot found = diagnosedRobot(r, rep);
  EXPECT_DOUBLE_EQ(found.tube(0).curvature, got["precurvature[tube 1]"]);
  EXPECT_DOUBLE_EQ(found.tube(1).curvature, got["precurvature[tube 2]"]);
  EXPECT_DOUBLE_EQ(found.tube(1).rotation_drive.offset, got["actuator_offset[tube 2]"]);
  EXPECT_NE(diagnosedRobotYaml(r, rep, "rec.csv").find("precurvature[tube 1] -> tubes[1].curvature"),
            std::string::npos);
}

// The detection limit of a candidate is what the selection can see: on a sweep with known white noise, a drive offset
// 1.6 x its limit (computed on a null recording) is accepted by the BIC criterion of every seed, one 0.4 x its limit by
// none; the limit of a parameter the recording does not depend on is infinite.
TEST(DetectionLimits, SeparateWhatTheFitCanAndCannotSee) {
  const PairBSweep w;
  const Robot& r = w.r;
  SimulationOptions s;
  s.seed = 3;
  FitOptions fo;
  fo.noise.twist = s.twist_sd;
  fo.noise.tip_position = s.position_sd;
  fo.noise.tip_tangent = s.tangent_sd;
  Workspace ws;
  const io::Recording null = simulateRecording(r, w.cmd, w.time, {}, s);
  const std::vector<char> all(static_cast<std::size_t>(null.rows()), 1);
  const Effect offset = nominalEffect(r, EffectKind::ActuatorOffset, 2);
  const double threshold = 10.0;
  const std::vector<DetectionLimit> lim = detectionLimits(r, null, {}, {offset}, all, fo, threshold, ws);
  ASSERT_EQ(lim.size(), 1u);
  ASSERT_TRUE(std::isfinite(lim[0].value));
  EXPECT_GT(lim[0].value, 0.0);
  EXPECT_LT(lim[0].value, 0.1);  // a sweep measured to 0.5 deg and 0.1 mm sees far less than 6 deg
  std::printf("detection limit of actuator_offset[2]: %.3f deg\n", lim[0].value * 180 / M_PI);
  for (const double factor : {1.6, 0.4}) {
    for (std::uint64_t seed : {11u, 12u, 13u}) {
      Effect e = offset;
      e.value = factor * lim[0].value;
      SimulationOptions si = s;
      si.seed = seed;
      const io::Recording rec = simulateRecording(r, w.cmd, w.time, {e}, si);
      const FitResult base = evaluateModel(r, rec, {}, all, fo, ws);
      const FitResult fit = fitEffects(r, rec, {offset}, all, fo, ws);
      const double dbic = bic(rec, fit.residuals, all, 1) - bic(rec, base.residuals, all, 0);
      std::printf("offset %.1f x limit, seed %d: delta BIC %.1f (fitted %.3f deg)\n", factor, static_cast<int>(seed),
                  dbic, fit.effects[0].value * 180 / M_PI);
      if (factor > 1)
        EXPECT_LT(dbic, -threshold);
      else
        EXPECT_GT(dbic, -threshold);
    }
  }
  // A sensor latency on a recording without time: no output depends on it.
  const Effect latency = nominalEffect(r, EffectKind::SensorLatency, 0);
  const std::vector<DetectionLimit> none = detectionLimits(r, null, {}, {latency}, all, fo, threshold, ws);
  EXPECT_FALSE(std::isfinite(none[0].value));
  EXPECT_FALSE(none[0].confounded);
  // An offset of tube 2 on top of a model that already holds one: its effect is that effect's, at any size.
  const std::vector<DetectionLimit> same = detectionLimits(r, null, {offset}, {offset}, all, fo, threshold, ws);
  EXPECT_FALSE(std::isfinite(same[0].value));
  EXPECT_TRUE(same[0].confounded);
}

// The replays integrate the equilibria with coarser steps than the library's default (kReplayMaxStep,
// kReplayMaxBending). On every example robot, along its default actuation sweep with boundary friction, their outputs
// stay within 2 um and 1e-4 rad of the default steps' (docs/diagnosis.md), and that is the coarse steps' error: halving
// the default steps changes the outputs by less than a tenth of it, or 10 nm (the solves' own tolerance shows there).
TEST(Discretisation, ReplayStepsStayFarBelowAnyTrackerNoiseOnTheExampleRobots) {
  const char* robots[] = {"dupont_lab_3tube", "three_tube_generic", "tube_pair_A", "tube_pair_B",
                          "single_tube",      "proc_intracardiac",  "proc_airway", "proc_sinus",
                          "medmpd_brain",     "medmpd_liver",       "medmpd_lung"};
  for (const char* name : robots) {
    SCOPED_TRACE(name);
    const Robot r = io::loadRobot(std::string(CTR_SOURCE_DIR) + "/examples/robots/" + name + ".yaml");
    ActuationOptions a;
    a.dt = 0;
    a.rows = 60;
    std::vector<Configuration> cmd;
    Eigen::VectorXd time;
    makeActuation(r, a, cmd, time);
    const std::vector<Effect> friction = {{EffectKind::BoundaryFriction, 0, 0.1}};
    PredictOptions replay, library, finer;
    const KinematicsOptions lib;
    library.replay.friction.kinematics.max_step = lib.max_step;
    library.replay.friction.kinematics.max_bending_per_step = lib.max_bending_per_step;
    finer.replay.friction.kinematics.max_step = lib.max_step / 2;
    finer.replay.friction.kinematics.max_bending_per_step = lib.max_bending_per_step / 2;
    EXPECT_EQ(replay.replay.friction.kinematics.max_step, kReplayMaxStep);
    EXPECT_EQ(SimulationOptions{}.predict.replay.friction.kinematics.max_step, lib.max_step);  // no inverse crime
    Workspace ws;
    const Prediction p = predict(r, cmd, time, friction, ws, replay);
    const Prediction q = predict(r, cmd, time, friction, ws, library);
    const Prediction h = predict(r, cmd, time, friction, ws, finer);
    ASSERT_EQ(p.ok, q.ok);
    ASSERT_EQ(q.ok, h.ok);
    double coarse_pos = 0, coarse_tan = 0, fine_pos = 0, fine_tan = 0;
    for (int k = 0; k < p.rows(); ++k) {
      if (!p.ok[static_cast<std::size_t>(k)]) continue;
      coarse_pos = std::max(coarse_pos, (p.tip_position.row(k) - q.tip_position.row(k)).cwiseAbs().maxCoeff());
      coarse_tan = std::max(coarse_tan, (p.tip_tangent.row(k) - q.tip_tangent.row(k)).cwiseAbs().maxCoeff());
      fine_pos = std::max(fine_pos, (q.tip_position.row(k) - h.tip_position.row(k)).cwiseAbs().maxCoeff());
      fine_tan = std::max(fine_tan, (q.tip_tangent.row(k) - h.tip_tangent.row(k)).cwiseAbs().maxCoeff());
    }
    std::printf("%-18s replay steps vs default: %.3g um, %.3g urad; default vs halved: %.3g um\n", name,
                1e6 * coarse_pos, 1e6 * coarse_tan, 1e6 * fine_pos);
    EXPECT_LT(coarse_pos, 2e-6);
    EXPECT_LT(coarse_tan, 1e-4);
    EXPECT_LT(fine_pos, std::max(1e-8, 0.1 * coarse_pos));
  }
}

// The diagnosis checks its replays' steps against the default steps on every recording: with a sweep's ordinary noise
// they are kept (error far below max_discretisation_error); when the check fails the default steps are used, and the
// diagnosis is then the one run with the default steps from the start.
TEST(Discretisation, ADiagnosisThatRefinesItsStepsIsTheOneAtTheDefaultSteps) {
  const PairBSweep w;
  SimulationOptions s;
  s.seed = 4;
  const io::Recording rec = simulateRecording(w.r, w.cmd, w.time, {{EffectKind::BoundaryFriction, 0, 0.15}}, s);
  DiagnoseOptions o;
  o.candidates = {EffectKind::BoundaryFriction, EffectKind::ActuatorOffset, EffectKind::TorsionalStiffness};
  const DiagnosisReport plain = diagnose(w.r, rec, o);
  EXPECT_FALSE(plain.discretisation.refined);
  EXPECT_EQ(plain.discretisation.max_step, kReplayMaxStep);
  EXPECT_GT(plain.discretisation.error_over_noise, 0.0);
  EXPECT_LT(plain.discretisation.error_over_noise, o.max_discretisation_error);
  ASSERT_EQ(plain.verdict, std::vector<std::string>{"boundary_friction"}) << plain.summary;

  DiagnoseOptions strict = o;
  strict.max_discretisation_error = 1e-12;
  const DiagnosisReport refined = diagnose(w.r, rec, strict);
  DiagnoseOptions at_default = o;
  const KinematicsOptions lib;
  at_default.predict.replay.friction.kinematics.max_step = lib.max_step;
  at_default.predict.replay.friction.kinematics.max_bending_per_step = lib.max_bending_per_step;
  const DiagnosisReport fine = diagnose(w.r, rec, at_default);
  EXPECT_TRUE(refined.discretisation.refined);
  EXPECT_EQ(refined.discretisation.max_step, lib.max_step);
  EXPECT_EQ(fine.discretisation.error_over_noise, 0.0);  // nothing to check at the default steps
  EXPECT_EQ(refined.verdict, fine.verdict);
  ASSERT_EQ(refined.final_effects.size(), fine.final_effects.size());
  for (std::size_t i = 0; i < fine.final_effects.size(); ++i)
    EXPECT_EQ(refined.final_effects[i].value, fine.final_effects[i].value);
  EXPECT_EQ(refined.final.bic, fine.final.bic);
  EXPECT_NEAR(plain.final_effects[0].value, fine.final_effects[0].value, 1e-3 * fine.final_effects[0].value);
  bool warned = false;
  for (const std::string& m : refined.warnings) warned = warned || m.find("integration steps") != std::string::npos;
  EXPECT_TRUE(warned);
}

// A fitted value at a limit of its search range is a bound, not an estimate: a drive offset of 0.75 rad (the range
// ends at 0.6) is kept in the fit at 0.6, flagged as such (finding, warning, JSON) and never named; one of 0.3 rad
// inside the range is named.
TEST(Verdict, AValueAtTheLimitOfItsSearchRangeIsReportedAsABound) {
  const PairBSweep w;
  DiagnoseOptions o;
  o.candidates = {EffectKind::ActuatorOffset};
  for (const double offset : {0.75, 0.3}) {
    SimulationOptions s;
    s.seed = 8;
    const io::Recording rec = simulateRecording(w.r, w.cmd, w.time, {{EffectKind::ActuatorOffset, 2, offset}}, s);
    const DiagnosisReport rep = diagnose(w.r, rec, o);
    ASSERT_EQ(rep.final_effects.size(), 1u) << rep.summary;
    const Finding* f = nullptr;
    for (const Finding& x : rep.findings)
      if (x.accepted) f = &x;
    ASSERT_NE(f, nullptr);
    bool warned = false;
    for (const std::string& m : rep.warnings)
      warned = warned || m.find("limit of the search range") != std::string::npos;
    if (offset > 0.6) {
      EXPECT_NEAR(rep.final_effects[0].value, 0.6, 1e-6);
      EXPECT_TRUE(f->at_range_limit);
      EXPECT_FALSE(f->named);
      EXPECT_TRUE(rep.verdict.empty()) << "a bound is never a named finding: " << rep.summary;
      EXPECT_TRUE(warned);
      EXPECT_NE(reportToJson(rep).find("\"at_range_limit\": true"), std::string::npos);
    } else {
      EXPECT_NEAR(rep.final_effects[0].value, offset, 0.01);
      EXPECT_FALSE(f->at_range_limit);
      EXPECT_TRUE(f->named);
      EXPECT_EQ(rep.verdict, std::vector<std::string>{"actuator_offset"});
      EXPECT_FALSE(warned);
    }
  }
}

// One name per effect in a verdict: a kind named on its own is not named again in an "X or Y"; of look-alikes the one
// with fewer parameters comes first; identical entries once.
TEST(Verdict, EachKindIsNamedOnceAndTheSimplerLookAlikeFirst) {
  using K = EffectKind;
  EXPECT_EQ(verdictNames({{K::TipLoad, K::Precurvature}, {K::Precurvature}}), std::vector<std::string>{"precurvature"});
  EXPECT_EQ(verdictNames({{K::Gravity, K::Precurvature}}), std::vector<std::string>{"precurvature or gravity"});
  EXPECT_EQ(verdictNames({{K::Precurvature, K::TipLoad, K::Gravity}}),
            std::vector<std::string>{"precurvature or gravity or tip_load"});
  EXPECT_EQ(verdictNames({{K::TranslationOffset, K::TranslationOffset}, {K::TranslationOffset}, {K::SensorLatency}}),
            (std::vector<std::string>{"translation_offset", "sensor_latency"}));
  EXPECT_EQ(verdictNames({{K::SensorLatency, K::ActuatorBacklash}, {K::BoundaryFriction}}),
            (std::vector<std::string>{"sensor_latency or actuator_backlash", "boundary_friction"}));
}
