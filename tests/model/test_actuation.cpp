// The drives between the commands and the tubes (actuation.hpp): the play operator against its closed form, the
// order play -> transmission errors -> offset, the play as path-dependent state carried by step() and replay(), and
// the tubes of a robot with actuation at the joints of its commands (the same equilibrium as the tubes alone there).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "ctr/model/friction.hpp"
#include "ctr/model/friction_ik.hpp"
#include "ctr/model/ik.hpp"
#include "ctr/model/replay.hpp"
#include "tube_factory.hpp"

using namespace ctr;
using ctr::test::makeTube;

namespace {

const double kNone = std::numeric_limits<double>::quiet_NaN();

Robot pair(double mu = 0.0) {
  return Robot("pair",
               {makeTube("outer", 0.018, 0.15, 6.49, 0.0334, 0.6), makeTube("inner", 0.018, 0.15, 6.49, 0.0511, 0.6)},
               FrictionCoefficients{mu, 0.0});
}

/// The pair with drives on the inner tube's rotation and the outer tube's translation.
Robot driven(double mu, double play, double offset) {
  Robot r = pair(mu);
  Tube inner = r.tube(1);
  inner.rotation_drive.play = play;
  inner.rotation_drive.offset = offset;
  Tube outer = r.tube(0);
  outer.translation_drive.offset = -0.002;
  return r.withTube(1, inner).withTube(0, outer);
}

Configuration pose(double relative) {
  return Configuration(Eigen::Vector2d(0, relative), Eigen::Vector2d(-0.018, -0.018));
}

}  // namespace

// A play of width w, centred at the first command: the joint stays until the command is w/2 away, then follows it
// w/2 behind; after a reversal it stays until the command has come back by the whole width. Closed form of a sweep
// 0 -> 1 -> 0 (rad) at 0.01 steps.
TEST(Drives, APlayLagsHalfItsWidthAndAReversalCostsTheWholeWidth) {
  const double w = 0.2;
  Drive d;
  d.play = w;
  double position = kNone;
  EXPECT_DOUBLE_EQ(d.joint(0.0, position), 0.0);
  for (int k = 1; k <= 100; ++k) {
    const double c = 0.01 * k;
    EXPECT_NEAR(d.joint(c, position), std::max(0.0, c - w / 2), 1e-15) << "up, command " << c;
  }
  for (int k = 99; k >= 0; --k) {
    const double c = 0.01 * k;
    // Back down from 1: the joint stays at 1 - w/2 until the command is below 1 - w, then follows w/2 above it.
    EXPECT_NEAR(d.joint(c, position), std::min(1.0 - w / 2, c + w / 2), 1e-15) << "down, command " << c;
  }
  Drive ideal;
  EXPECT_TRUE(ideal.ideal());
  double p = kNone;
  EXPECT_EQ(ideal.joint(0.3, p), 0.3);
}

// The memoryless part, in its documented order: ratio error, then the periodic error at the value it gives, then the
// offset; a stage error on translations.
TEST(Drives, TransmissionErrorsThenTheOffset) {
  Drive d;
  d.ratio_error = 0.02;
  d.ratio_reference = 0.5;
  d.periodic = {0.01, -0.02, 0.005, 0.003};
  d.offset = 0.1;
  const double x = 1.3;
  const double r = x + 0.02 * (x - 0.5);
  const double expected =
      r + 0.01 * std::cos(r) - 0.02 * std::sin(r) + 0.005 * std::cos(2 * r) + 0.003 * std::sin(2 * r) + 0.1;
  EXPECT_DOUBLE_EQ(d.transmit(x), expected);
  Drive s;
  s.stage = {1e-4, -2e-4, 3e-4};
  s.stage_reference = -0.05;
  s.stage_scale = 0.05;
  const double u = (-0.02 + 0.05) / 0.05;
  EXPECT_DOUBLE_EQ(s.transmit(-0.02), -0.02 + u * (1e-4 + u * (-2e-4 + u * 3e-4)));
  EXPECT_FALSE(d.ideal());
}

// The tubes of a robot with drives sit at the joints of the command: initialState and step give the equilibrium of
// the tubes alone at jointsOf(command), the state remembers the command, the joints and the plays.
TEST(Drives, StepPutsTheTubesAtTheJointsOfTheCommand) {
  const Robot r = driven(0.0, 0.3, 0.05);
  const Robot tubes = r.withoutActuation();
  ASSERT_TRUE(hasActuation(r));
  ASSERT_FALSE(hasActuation(tubes));
  Workspace ws;
  StepResult s = initialState(r, pose(0.0), ws);
  ASSERT_TRUE(s.summary.converged) << s.summary.message;
  // Centred play: inner rotation 0 + offset 0.05; the outer tube 2 mm further in, projected to keep the nesting.
  DriveState fresh;
  const Configuration j0 = jointsOf(r, pose(0.0), fresh);
  EXPECT_DOUBLE_EQ(j0.alpha[1], 0.05);
  EXPECT_EQ(s.state.q.alpha, j0.alpha);
  EXPECT_EQ(s.state.q.beta, j0.beta);
  EXPECT_EQ(s.state.command.alpha, pose(0.0).alpha);
  EXPECT_DOUBLE_EQ(s.state.drives.rotation[1], 0.0);
  EXPECT_TRUE(std::isnan(s.state.drives.rotation[0])) << "no play on the outer rotation: no history kept";
  const Solution alone = solve(tubes, j0, ws);
  EXPECT_LT((s.solution.tip_position - alone.tip_position).norm(), 1e-12);

  // Up by 1 rad: the inner tube turns 1 - 0.15 (+ offset); back by 0.2: within the play, the tubes do not move.
  s = step(r, s.state, pose(1.0), ws);
  ASSERT_TRUE(s.summary.converged) << s.summary.message;
  EXPECT_NEAR(s.solution.q.alpha[1], 1.0 - 0.15 + 0.05, 1e-15);
  const Eigen::Vector3d up = s.solution.tip_position;
  s = step(r, s.state, pose(0.8), ws);
  ASSERT_TRUE(s.summary.converged) << s.summary.message;
  EXPECT_NEAR(s.solution.q.alpha[1], 1.0 - 0.15 + 0.05, 1e-15);
  EXPECT_LT((s.solution.tip_position - up).norm(), 1e-9) << "a reversal within the play does not move the tubes";
  EXPECT_EQ(s.state.command.alpha[1], 0.8);
  // The same command reached from below: the play engaged on the other side (0.8 - 0.15 against 1.0 - 0.15 held
  // from above), the tubes 0.2 rad behind.
  StepResult below = initialState(r, pose(0.0), ws);
  below = step(r, below.state, pose(0.8), ws);
  EXPECT_NEAR(s.solution.q.alpha[1] - below.solution.q.alpha[1], 0.2, 1e-12);
  EXPECT_GT((s.solution.tip_position - below.solution.tip_position).norm(), 1e-3) << "hysteresis from the play";
}

// The replay of a robot with drives is the replay of its tubes at the joints of the commands taken in order; each
// row's state carries its command and the plays' positions as the chain of step() from the first row gives them.
TEST(Drives, ReplayIsTheTubesReplayAtTheJointsOfTheCommandsInOrder) {
  for (double mu : {0.0, 0.1}) {
    const Robot r = driven(mu, 0.25, -0.04);
    std::vector<Configuration> commands, joints;
    DriveState drives;
    for (double a : {0.0, 0.4, 0.9, 0.7, 0.3, 0.5, 1.2, 0.2}) {
      commands.push_back(pose(a));
      joints.push_back(jointsOf(r, pose(a), drives));
    }
    Workspace ws;
    const std::vector<ReplayRow> a = replay(r, commands, ws), b = replay(r.withoutActuation(), joints, ws);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t k = 0; k < a.size(); ++k) {
      ASSERT_TRUE(a[k].ok) << "mu " << mu << " row " << k << ": " << toString(a[k].failure);
      EXPECT_EQ(a[k].result.solution.tip_position, b[k].result.solution.tip_position) << "mu " << mu << " row " << k;
      EXPECT_EQ(a[k].result.solution.q.alpha, joints[k].alpha);
    }
    StepResult chain = initialState(r, commands[0], ws);
    for (std::size_t k = 0; k < a.size(); ++k) {
      if (k > 0) chain = step(r, chain.state, commands[k], ws);
      const HysteresisState& h = a[k].result.state;
      EXPECT_EQ(h.lastCommand().alpha, commands[k].alpha) << "row " << k;
      EXPECT_EQ(h.lastCommand().beta, commands[k].beta) << "row " << k;
      ASSERT_EQ(h.drives.rotation.size(), 2) << "row " << k;
      EXPECT_EQ(h.drives.rotation[1], chain.state.drives.rotation[1]) << "row " << k;
      EXPECT_TRUE(std::isnan(h.drives.rotation[0])) << "row " << k;
      // Carried on, the replay's state steps like the chain's: the next command lands on the same joints.
      if (k + 1 < a.size()) {
        const StepResult next = step(r, h, commands[k + 1], ws);
        EXPECT_EQ(next.solution.q.alpha, joints[k + 1].alpha) << "row " << k;
      }
    }
  }
}

// The inverse of a drive: the command that puts the joint where it is wanted from the play's position. Going up, the
// play is taken up below the target (command half the width beyond it); going down, above; staying, no play.
TEST(Drives, TheCommandForAJointIsTheInverseOfTheDrive) {
  Drive d;
  d.play = 0.3;
  d.ratio_error = -0.04;
  d.ratio_reference = 0.2;
  d.periodic = {0.01, -0.015, 0.004, 0.002};
  d.offset = 0.07;
  for (double position : {kNone, -0.5, 0.4})
    for (double joint : {-1.0, -0.2, 0.3, 0.45, 2.0}) {
      const double c = d.command(joint, position);
      double p = position;
      EXPECT_NEAR(d.joint(c, p), joint, 1e-12) << "from " << position << " to " << joint;
    }
  Drive play;
  play.play = 0.3;
  EXPECT_DOUBLE_EQ(play.command(1.0, 0.5), 1.15);  // up: half the width beyond
  EXPECT_DOUBLE_EQ(play.command(0.2, 0.5), 0.05);  // a reversal: the whole width from the last command going up
  EXPECT_DOUBLE_EQ(play.command(0.5, 0.5), 0.5);   // stays
  Drive stage;
  stage.stage = {2e-4, -1e-4, 5e-5};
  stage.stage_reference = -0.02;
  stage.stage_scale = 0.004;
  stage.offset = -3e-4;
  double none = kNone;
  EXPECT_NEAR(stage.joint(stage.command(-0.031, kNone), none), -0.031, 1e-15);
}

// Inverse kinematics through the drives: the tubes' joints are solved on the tubes alone and the commands compensate
// the offsets and a ratio error (frictionless, no history: plays centred) -- forward kinematics of the commands
// through the drives is on the target; the joints themselves sent as commands miss it by the drives' effect.
TEST(Drives, InverseKinematicsCompensatesTheOffsets) {
  Robot r = pair();
  Tube inner = r.tube(1), outer = r.tube(0);
  inner.rotation_drive.offset = 0.15;
  outer.rotation_drive.offset = -0.1;
  outer.rotation_drive.ratio_error = 0.03;
  r = r.withTube(1, inner).withTube(0, outer);
  Workspace ws;
  DriveState centred;
  const Configuration truth(Eigen::Vector2d(0.3, 1.4), Eigen::Vector2d(-0.03, -0.03));
  const Eigen::Vector3d target = solve(r.withoutActuation(), jointsOf(r, truth, centred), ws).tip_position;
  const IkResult ik = inverseKinematics(r, IkTarget(target), ws);
  ASSERT_TRUE(ik.summary.reached()) << ik.summary.message;
  DriveState fresh;
  const Configuration joints = jointsOf(r, ik.q, fresh);
  EXPECT_LT((solve(r.withoutActuation(), joints, ws).tip_position - target).norm(), 1.01e-5);
  EXPECT_NEAR(ik.q.alpha[1] - ik.solution.q.alpha[1], -0.15, 1e-12) << "the command compensates the offset";
  DriveState naive_state;
  const Eigen::Vector3d naive = solve(r.withoutActuation(), jointsOf(r, ik.solution.q, naive_state), ws).tip_position;
  RecordProperty("tip_error_uncompensated_m", std::to_string((naive - target).norm()));
  EXPECT_GT((naive - target).norm(), 1e-3) << "the uncompensated commands miss by the offsets' effect";
}

// Friction-aware inverse kinematics through play, offset and friction along a path: the commands replayed through the
// drives from the same start put the tip on every target; the joints sent as commands (a controller that ignores the
// drives) miss by far more, and the reversal costs the play.
TEST(Drives, FrictionAwareInverseKinematicsCompensatesPlayOffsetAndFriction) {
  Robot r = pair(0.1);
  Tube inner = r.tube(1);
  inner.rotation_drive.play = 0.3;
  inner.rotation_drive.offset = 0.05;
  r = r.withTube(1, inner);
  Workspace ws;
  const StepResult start = initialState(r, pose(0.0), ws);
  ASSERT_TRUE(start.summary.converged);
  // Targets on a path that goes up and comes back (a reversal of the inner tube).
  std::vector<IkTarget> targets;
  {
    StepResult s = start;
    for (double a : {0.4, 0.8, 1.2, 0.9, 0.6}) {
      s = step(r, s.state, pose(a), ws);
      ASSERT_TRUE(s.summary.converged);
      targets.emplace_back(s.solution.tip_position);
    }
  }
  FrictionIkOptions o;
  const std::vector<FrictionIkResult> res = frictionInverseKinematicsPath(r, start.state, targets, ws, o);
  ASSERT_EQ(res.size(), targets.size());
  StepResult replayed = start, naive = start;
  double worst = 0.0, worst_naive = 0.0;
  for (std::size_t k = 0; k < res.size(); ++k) {
    ASSERT_TRUE(res[k].summary.reached()) << k << ": " << res[k].summary.message;
    EXPECT_GT(res[k].cost.drive_alpha_difference, 0.0);
    replayed = step(r, replayed.state, res[k].q, ws, o.friction);
    worst = std::max(worst, (replayed.solution.tip_position - targets[k].position).norm());
    naive = step(r, naive.state, res[k].step.solution.q, ws, o.friction);  // the joints sent as commands
    worst_naive = std::max(worst_naive, (naive.solution.tip_position - targets[k].position).norm());
  }
  RecordProperty("tip_error_compensated_m", std::to_string(worst));
  RecordProperty("tip_error_uncompensated_m", std::to_string(worst_naive));
  EXPECT_LT(worst, 2 * o.ik.tolerance);
  EXPECT_GT(worst_naive, 10 * worst) << "compensated " << worst << " m, uncompensated " << worst_naive << " m";
  // The inner tube's command is its joint less the offset, half the play (0.15 rad) beyond it in the direction the
  // joint moved (none when it stays): after moving up and turning back, the commands come back by the joint's move
  // plus the play's whole width.
  int reversals = 0;
  double last_direction = 0.0, position = 0.0;  // the play's position at the start (centred on the command 0)
  for (std::size_t k = 0; k < res.size(); ++k) {
    const double x = res[k].step.solution.q.alpha[1] - 0.05;
    const double move = x - position;
    const double direction = std::abs(move) < 1e-12 ? 0.0 : (move > 0 ? 1.0 : -1.0);
    EXPECT_NEAR(res[k].q.alpha[1], x + direction * 0.15, 1e-9) << k;
    if (direction != 0.0) {
      reversals += last_direction != 0.0 && direction != last_direction;
      last_direction = direction;
    }
    position = x;
  }
  std::string joints;
  for (const FrictionIkResult& x : res)
    joints += " (" + std::to_string(x.step.solution.q.alpha[0]) + ", " + std::to_string(x.step.solution.q.alpha[1]) +
              ", " + std::to_string(x.step.solution.q.beta[0]) + ")";
  EXPECT_GE(reversals, 1) << "the path turns the inner tube back:" << joints;
}

// Values a drive cannot have are refused by the robot.
TEST(Drives, BadDriveValuesAreRefused) {
  Tube bad = pair().tube(1);
  bad.rotation_drive.play = -0.1;
  EXPECT_THROW(pair().withTube(1, bad), std::invalid_argument);
  bad.rotation_drive.play = 7.0;
  EXPECT_THROW(pair().withTube(1, bad), std::invalid_argument);
  bad = pair().tube(1);
  bad.rotation_drive.stage = {1e-4, 0, 0};
  EXPECT_THROW(pair().withTube(1, bad), std::invalid_argument);
}
