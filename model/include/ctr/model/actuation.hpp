/// @file actuation.hpp
/// @brief The drives between the commands and the tubes (docs/formats.md, robot `actuation:` block): per tube and
/// joint (rotation, translation) a play (dead band), a transmission error and an offset. A play has memory: its
/// position is path-dependent state (DriveState, carried in HysteresisState next to the friction memory).
#pragma once

#include <Eigen/Core>
#include <array>

namespace ctr {

/// @brief One drive: the joint value (tube rotation in rad, or translation in m) a command gives. In this order:
/// the play (the joint side lags the command by up to half the width, and follows it once the play is taken up),
/// then the transmission errors (functions of the value after the play), then the offset. An ideal drive (all
/// zero) gives the command itself.
struct Drive {
  double offset = 0.0;  ///< Constant added last (rad or m).
  double play = 0.0;    ///< Full width of the dead band (rad or m); >= 0. A reversal costs this much command.
  /// Drive ratio error: + ratio_error (x - ratio_reference), x the value after the play (a gear or belt ratio off by
  /// a fraction ratio_error).
  double ratio_error = 0.0;
  double ratio_reference = 0.0;  ///< Where the ratio error is zero (rad or m).
  /// Periodic transmission error of a rotation drive: + p0 cos x + p1 sin x + p2 cos 2x + p3 sin 2x (rad), applied
  /// after the ratio error (at the value it gives).
  std::array<double, 4> periodic{};
  /// Stage error of a translation drive: + u (c0 + u (c1 + u c2)) with u = (x - stage_reference) / stage_scale (m),
  /// applied after the ratio error.
  std::array<double, 3> stage{};
  double stage_reference = 0.0;  ///< m
  double stage_scale = 1.0;      ///< m; > 0

  /// @brief True when the joint value is the command (no play, no error, no offset).
  bool ideal() const;
  /// @brief The memoryless part: transmission errors and offset applied to a value after the play.
  double transmit(double x) const;
  /// @brief The value after the play that transmit() turns into `joint` (the inverse of the memoryless part; Newton
  /// on the monotone transmission, NaN when it does not converge: transmission errors too large to invert).
  double untransmit(double joint) const;
  /// @brief The command that puts the joint at `joint` from the play position `position` (NaN: no history): the
  /// play taken up on the side of the move (half the width beyond the target), none when the joint stays. The
  /// inverse of joint(): joint(command(j, p), p) == j up to rounding.
  double command(double joint, double position) const;
  /// @brief The joint value for `command`, updating `position` (the play's output; NaN when the drive has no
  /// history yet: the play is then taken as centred on this command). Without a play `position` is left as it is.
  double joint(double command, double& position) const;
};

/// @brief The plays' positions of a robot's drives (value after the play, per tube); NaN where a drive has no play
/// or no history yet. Empty vectors: no drive has one.
struct DriveState {
  Eigen::VectorXd rotation;
  Eigen::VectorXd translation;
};

}  // namespace ctr
