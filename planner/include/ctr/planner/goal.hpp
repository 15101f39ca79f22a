/// @file goal.hpp
/// @brief Goal region on the tip position (world frame) with a tolerance and an optional tip-direction cone.
/// Sampleable (for RRTConnect, PRM, BIT*...) through a pool of goal configurations found by the library's inverse
/// kinematics (ctr/model/ik.hpp) on the frictionless model, each accepted only if valid in the planning mode (robust
/// mode: and only if every shape of its friction band reaches the target, or every equilibrium a final approach move
/// leaves the robot in: an approach goal).
#pragma once

#include <ompl/base/goals/GoalSampleableRegion.h>
#include <ompl/util/RandomNumbers.h>

#include <limits>
#include <mutex>
#include <optional>
#include <random>
#include <string>

#include "ctr/planner/state_space.hpp"

namespace ctr::planner {

/// @brief Tip goal specification.
struct TipGoalSpec {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< Target (world, m).
  double tolerance = 2e-3;                             ///< Tip distance accepted (m).
  std::optional<Eigen::Vector3d> direction;            ///< Desired tip tangent (world, unit).
  double cone_angle = M_PI;                            ///< Accepted angle from `direction` (rad).
  /// Robust mode: where no friction band holds the target, a goal may be held after a final approach move (the path
  /// then ends with it; docs/planning.md "Final approach"). False: every band must hold the target itself.
  bool final_approach = true;
};

/// @brief Inverse kinematics (frictionless model; ctr::inverseKinematics of ctr/model/ik.hpp with the planner's
/// discretisation and min_protrusion, no restarts): a configuration near q0 with the tip at `target` (world), within
/// 10 um when reached. Returns the tip error reached (m), or infinity if the model did not converge at q0.
double inverseKinematics(const Context& ctx, const Eigen::Vector3d& target, Configuration& q, int iterations = 40);

/// @brief Tip goal region.
class TipGoal : public ompl::base::GoalSampleableRegion {
 public:
  TipGoal(const ompl::base::SpaceInformationPtr& si, std::shared_ptr<const Context> ctx, TipGoalSpec spec);
  /// @brief Distance of the tip to the target (m), plus 0.05 m per rad outside the direction cone. In robust mode,
  /// within the tolerance, the largest such distance over the friction band (the goal holds for every history).
  double distanceGoal(const ompl::base::State* st) const override;
  void sampleGoal(ompl::base::State* st) const override;
  unsigned int maxSampleCount() const override;
  /// @brief Fills the pool with up to `count` valid goal configurations within `seconds` (of process CPU time when
  /// `cpu_clock`, else wall-clock). Returns the pool size. With `target` > `count` the pool keeps growing up to
  /// `target` during planning (sampleGoal tries one more candidate every other call). The candidates follow one
  /// random sequence seeded by the first call; later calls continue it.
  /// In robust mode a goal configuration must reach the target with every shape of its friction band; IK aims the
  /// frictionless tip so that the band's tips are centred on the target.
  std::size_t fillPool(std::size_t count, double seconds, std::uint64_t seed, bool cpu_clock = false,
                       std::size_t target = 0);
  /// @brief Why the pool is empty ("" if it is not): no IK solution, (robust mode) no band within the tolerance, or
  /// no valid configuration among those that reach the target.
  std::string emptyPoolReason() const;
  const TipGoalSpec& spec() const { return spec_; }
  /// @brief Tip error and direction error (rad) of a shape (base-frame solution).
  std::pair<double, double> errors(const Solution& sol) const;
  /// @brief Robust mode: the final approach move (a command difference: neighbouring tubes turned against each other,
  /// no translation) that a path ending at the pool state `st` must append, when `st` is the start of an approach
  /// goal; nullopt for any other state.
  std::optional<Configuration> approachMove(const ompl::base::State* st) const;
  /// @brief Robust mode: the goal distance (as distanceGoal) of every equilibrium the move q -> q + `move` can end in
  /// from any history, i.e. from every shape of the friction band at q (each contact stuck at its torque there:
  /// stuckStateAt, then ctr::step), for every robust corner and, with a range of friction.boundary, at its lower end
  /// too. With `vertices` false only from the frictionless shape (a cheap estimate of where the band ends). Optionally
  /// the centre of their tips. Infinity when a step does not converge or snaps.
  double approachDistance(const Configuration& q, const Configuration& move, bool vertices,
                          Eigen::Vector3d* centre = nullptr) const;

 private:
  double goalDistance(const Eigen::Vector3d& tip, const Eigen::Vector3d& tangent) const;
  /// Largest goal distance over the vertex shapes of every robust corner's friction band at command q (one band
  /// without ranges and plays); optionally the centre of their tips.
  double bandDistance(const Configuration& q, Eigen::Vector3d* center = nullptr) const;
  /// One IK candidate from a random configuration; adds it to the pool if it is a valid goal.
  bool tryCandidate() const;
  /// Robust mode, a candidate (joints `q`, frictionless tip on the target) whose band misses the target: a valid
  /// approach goal near it (its start command, wrapped, in `start`, the move in `move`, its approachDistance in
  /// `distance`), or false. Counts what it tried for emptyPoolReason.
  bool tryApproach(const Configuration& q, Configuration& start, Configuration& move, double& distance) const;
  /// Counts why a goal configuration on the target was rejected (the caller holds the lock).
  void countRejected(Failure f) const;
  /// The pool entry of the approach goal whose start is q (as stored), -1 if none (the caller holds the lock).
  long approachEntry(const Configuration& q) const;
  /// q as the state space stores it (rotations wrapped).
  Configuration stored(const Configuration& q) const;
  std::shared_ptr<const Context> ctx_;
  const CtrStateSpace* space_;
  TipGoalSpec spec_;
  mutable std::vector<Configuration> pool_;
  mutable std::vector<Configuration> approach_;    // per pool entry: its final approach move (size 0: none)
  mutable std::vector<double> approach_distance_;  // per pool entry: its goal distance after the approach
  mutable std::size_t target_ = 0;
  mutable std::mt19937_64 gen_;
  bool seeded_ = false;
  mutable double best_band_ = std::numeric_limits<double>::infinity();
  mutable std::size_t ik_reached_ = 0, band_reached_ = 0;  // candidates with the tip / the whole band on target
  // Robust mode: candidates whose final approach was tried, and the closest approach distance.
  mutable std::size_t approach_tried_ = 0;
  mutable double best_approach_ = std::numeric_limits<double>::infinity();
  // Of ik_reached_ (exact / frictionless modes): outside the goal region (direction cone), colliding, unstable.
  mutable std::size_t rejected_goal_ = 0, rejected_collision_ = 0, rejected_unstable_ = 0, rejected_not_unique_ = 0;
  mutable std::mutex mutex_;
  mutable ompl::RNG rng_;
};

}  // namespace ctr::planner
