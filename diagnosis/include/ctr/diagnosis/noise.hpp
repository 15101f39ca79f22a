/// @file noise.hpp
/// @brief The measurement noise a quasi-static model must meet, per measured quantity: given by the user (a
/// tracker's specification), measured by rows that repeat a pose, or estimated from neighbouring rows -- with its
/// source, its uncertainty (degrees of freedom) and whether the recording can separate it from model error.
///
/// Conventions: twist and tip position per scalar component (rad, m); tip tangent per direction normal to the
/// measured tangent (a unit vector is noisy in two directions; its residual has 2 degrees of freedom per row).
#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ctr/diagnosis/forward_model.hpp"
#include "ctr/diagnosis/residuals.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/model/replay.hpp"

namespace ctr::diagnosis {

/// @brief Noise standard deviations given by the user (docs/formats.md `noise` source `given`); unset = estimated.
struct GivenNoise {
  std::optional<double> twist, tip_position, tip_tangent;
  std::optional<double> of(Quantity q) const;
  bool empty() const { return !twist && !tip_position && !tip_tangent; }
};

/// @brief Parses "QUANTITY=SIGMA[,QUANTITY=SIGMA]" (e.g. "tip_position=0.5mm,tip_tangent=1deg,twist=2deg"); units m,
/// mm, um (positions), rad, deg (angles; the tangent's per normal direction). Throws std::invalid_argument naming the
/// item and what is wrong.
GivenNoise parseGivenNoise(const std::string& text);

/// @brief The part of a residual, or of a difference of residuals or measurements, of quantity `q` that carries noise
/// (the conventions above): twist components wrapped to (-pi, pi], a tip tangent's part normal to the measured tangent
/// `t` (a 3-vector; ignored for the other quantities).
Eigen::VectorXd noisePart(Quantity q, Eigen::VectorXd e, const Eigen::VectorXd& t);

/// @brief Consecutive rows with the same command collapsed into one row (a visit): the robot did not move between
/// them, so their spread is the tracker's jitter.
struct Visits {
  io::Recording recording;     ///< One row per visit: the mean of its frames (tangent re-normalised, twist circular).
  std::vector<int> first_row;  ///< 0-based row of the original recording where each visit starts.
  std::vector<int> frames;     ///< Rows averaged into each visit.
  /// Jitter per quantity (same conventions as the noise), from the spread of frames about their visit's mean, with
  /// its degrees of freedom; empty when no visit has two frames.
  std::map<Quantity, std::array<double, 2>> jitter;  ///< {sigma, dof}
  /// @brief True when some visit has more than one frame.
  bool anyRepeated() const;
};

/// @brief Collapses runs of identical commands (within 1e-12) into visits. Time: the first frame's.
Visits collapseFrames(const io::Recording& rec);

/// @brief The noise of one quantity, with where it came from.
struct NoiseEstimate {
  double sigma = 0.0;                            ///< Standard deviation used (see the file comment for the convention).
  double dof = 0.0;                              ///< Degrees of freedom of the estimate (infinity when given).
  std::array<double, 2> interval95{{0.0, 0.0}};  ///< 95 % interval of sigma.
  std::string source;                            ///< "given", "repeated" (returns to a pose) or "neighbours".
  /// True when the recording separates the noise from model error: given, repeated poses, or neighbour differences
  /// that do not grow with the neighbours' distance. False: an upper bound only (sparse pose sets).
  bool supported = true;
  /// Along a path: whether the residual differences the estimate uses are those of independent noise (differences two
  /// rows apart no larger than those of neighbouring rows). False: the stream is filtered, oversampled or holds model
  /// error that changes from row to row; the noise cannot be told from these data and `supported` is false too.
  /// Always true for other sources.
  bool white = true;
  double serial_ratio = 0.0;  ///< Variance of differences two rows apart over that of neighbours (0: not tested).
  double serial_p = 1.0;      ///< One-sided p-value that it exceeds 1.
  int pairs = 0;              ///< Differences the estimate rests on.
  double jitter = 0.0;        ///< Frame-to-frame jitter (0 when the recording has no repeated frames).
  int frames = 1;             ///< Typical frames per visit (the noise is that of a visit's mean).
  std::string note;           ///< Plain words: how it was estimated, and any caveat.
};

/// @brief The noise of every measured quantity.
struct NoiseReport {
  std::map<Quantity, NoiseEstimate> by_quantity;
  /// The levels and their degrees of freedom, as the fits and tests use them.
  NoiseLevels levels() const;
  /// True when every quantity's noise is supported by the data or given.
  bool supported() const;
  /// True when no quantity's neighbour differences failed the test of serial correlation (NoiseEstimate::white).
  bool white() const;
};

/// @brief Estimates the noise from residuals of a model whose error is smooth along the path and across nearby
/// configurations (the nominal model). Given values are used as they are. Otherwise, in order:
/// - repeated: pairs of rows with the same command, each reached after a long move (returns to a pose in a pose set),
///   at which the model predicts the same: their residual differences are pure noise, whatever the model error (rows
///   along a short path are left out: a sweep passes a command in both directions, with hysteresis in between);
/// - neighbours: pseudo-residuals that cancel smooth model error -- second differences along the path where
///   consecutive moves are continuations shorter than isLongMove's steps (a densely sampled trajectory), else
///   differences between nearest neighbours in configuration space. The closer half of the differences is used; when
///   the differences grow with the neighbours' distance (model error), the estimate is an upper bound (`supported`
///   false).
/// Every estimate is the mean of squares after a median-based screen of gross outliers (a snap, a glitch), corrected
/// for the screen (unbiased for Gaussian noise); `dof` counts the noisy components it rests on (fewer for the
/// correlated second differences). The jitter of repeated frames (visits) bounds the noise from below.
NoiseReport estimateNoise(const io::Recording& rec, const Residuals& r, const Prediction& p,
                          const std::vector<char>& use, const GivenNoise& given = {}, const Visits* visits = nullptr);

}  // namespace ctr::diagnosis
