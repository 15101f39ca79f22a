/// @file uncertainty.hpp
/// @brief Ranges of a robot's friction and drives (a query's intervals, or the 95 % intervals of a diagnosis): the
/// box of robots robust mode plans for, the robots it checks (robustCorners: one per corner of the drives' joint box,
/// friction at its upper bounds) and the robots a plan is replayed with (the corners of the box and random samples
/// inside it).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ctr/model/configuration.hpp"
#include "ctr/model/robot.hpp"

namespace ctr::planner {

/// @brief One uncertain value of a robot and its range [lo, hi] (SI units: rad, m, or a coefficient).
struct RangeDimension {
  enum class Kind {
    BoundaryFriction,     ///< friction.boundary (mu')
    DistributedFriction,  ///< friction.distributed (mu)
    RotationOffset,       ///< tubes[tube].actuation.rotation.offset
    RotationPlay,         ///< tubes[tube].actuation.rotation.play (full width)
    TranslationOffset,    ///< tubes[tube].actuation.translation.offset
    TranslationPlay,      ///< tubes[tube].actuation.translation.play (full width)
  };
  Kind kind = Kind::BoundaryFriction;
  int tube = 0;  ///< 1-based (drives only).
  double lo = 0.0, hi = 0.0;
  /// @brief "friction.boundary", "tube 2 rotation play", ...
  std::string name() const;
};

/// @brief The ranges of a planning problem: at most one per value, each with lo <= hi.
using RobotRanges = std::vector<RangeDimension>;

/// @brief Checks ranges against a robot: tubes exist, finite lo <= hi, one range per value, and both ends of every
/// range are values the robot description accepts (the robot's own checks: friction >= 0, plays >= 0 and less than
/// a turn / the tube, |rotation offset| <= pi, ...). Throws std::invalid_argument naming the range or the key.
void checkRanges(const Robot& robot, const RobotRanges& ranges);

/// @brief The robot at one point of the box: `values[i]` for ranges[i] (the robot's own value elsewhere).
Robot robotAt(const Robot& robot, const RobotRanges& ranges, const std::vector<double>& values);

/// @brief One robot robust mode checks: `drives` has no play (its joints are a function of the command), and the
/// joints of a command q are jointsOf(drives, q + shift) (a play's extreme positions as a shift of the command
/// before the transmission).
struct RobustCorner {
  Robot drives;         ///< The robot with memoryless drives, friction at the ranges' upper bounds.
  Robot tubes;          ///< The same without its drives (solved at joints).
  Configuration shift;  ///< Command shift of this corner (each play at one end of its band).
  /// @brief The joints of command q at this corner.
  Configuration joints(const Configuration& q) const;
};

/// @brief Why the robot's joints depend on the unwrapped command, "" when they do not: a rotation drive with a ratio
/// error (a state kept within one turn then does not determine its joints).
std::string unwrappedCommandDependence(const Robot& robot);

/// @brief The robots robust mode checks for `robot` over `ranges`. Friction at its upper bounds (the friction band
/// of a larger coefficient contains every equilibrium of a smaller one: its torque box contains theirs). Each drive
/// whose joint can lie in an interval — a play (any history) or an offset range — adds a dimension with its two
/// extremes (lowest offset with the play at its lower end, highest offset with the play at its upper end: the
/// transmission is monotone); one corner per combination (2^k). Without ranges and plays: the robot itself.
/// Throws std::invalid_argument when a rotation drive has a ratio error (its joint depends on the unwrapped command).
std::vector<RobustCorner> robustCorners(const Robot& robot, const RobotRanges& ranges);

/// @brief Points of the box a plan is replayed at: every corner (2^d for the d ranges with lo < hi), then `samples`
/// uniform random points inside (seeded). Values per point in the order of `ranges`.
std::vector<std::vector<double>> rangeReplayPoints(const RobotRanges& ranges, int samples, std::uint64_t seed);

/// @brief The ranges of a diagnosis (`ctr diagnose --json`): the 95 % interval (`interval95`) of every named effect of
/// its final model that a range can hold (boundary_friction, distributed_friction, actuator_backlash,
/// actuator_offset, translation_backlash, translation_offset). Effects of other kinds are listed in `skipped` (their
/// value is the robot description's). Throws ctr::io::InputError naming the file for a file that is not a diagnosis.
RobotRanges rangesFromDiagnosis(const std::string& path, std::vector<std::string>* skipped = nullptr);

}  // namespace ctr::planner
