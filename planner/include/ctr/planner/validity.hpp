/// @file validity.hpp
/// @brief Validity of configurations and motions in the three modes.
///
/// - Frictionless: admissible, converged, stable, collision-free; motions are followed forward along the
///   equilibrium branch (continuation from the source) and are invalid if the branch snaps.
/// - Robust: the whole friction band (every admissible history) at a configuration is converged, stable and
///   collision-free; along a motion every band vertex is followed forward and must not snap. With ranges of the
///   robot's values or drive plays, the band of every robust corner (Context::robustCorners).
/// - Exact: the state's cached physics (propagated forward through the stick-slip model) is valid and its shape is
///   collision-free.
#pragma once

#include <ompl/base/MotionValidator.h>
#include <ompl/base/StateValidityChecker.h>

#include "ctr/planner/state_space.hpp"

namespace ctr::planner {

/// @brief Result of checking one configuration.
struct ConfigurationCheck {
  bool ok = false;
  Failure failure = Failure::None;  ///< Why not.
  std::string message;              ///< Why not, in words.
  /// The (frictionless) shape checked; its backbone holds the geometry (robust mode: also the tubes' angles).
  Solution shape;
};

/// @brief Frictionless check of q (cold solve, or warm from `warm`).
ConfigurationCheck checkFrictionless(const Context& ctx, const Configuration& q, ThreadScratch& t,
                                     const Solution* warm = nullptr);
/// @brief Robust check: every shape of the friction band of every robust corner at command q, and each band certified
/// unique (uniqueness.hpp: no history reaches another equilibrium with the same contact torques; Failure::NotUnique).
ConfigurationCheck checkRobust(const Context& ctx, const Configuration& q, ThreadScratch& t);

/// @brief Robust mode's states stand for the friction band of their configuration, so the robot a start history
/// leaves at command q (its equilibrium `replayed`) must lie in it: every tip twist within the extremes of the robust
/// corners' bands, widened by the snap threshold (further is another equilibrium). Returns why not ("" when it
/// does).
std::string robustStartOutsideBand(const Context& ctx, const Configuration& q, const Solution& replayed,
                                   ThreadScratch& t);

/// @brief Forward check of the straight-line motion q0 -> q1 at the context's resolutions, in the context's mode
/// (frictionless or robust; exact mode uses the propagator). Returns the fraction of the motion that is valid
/// (1 when all of it), the first failure's message (in words) and its kind. The motion is followed by followMove
/// (model/follow.hpp) with the context's resolutions and snap threshold, stopping at the first snap.
double checkMotionForward(const Context& ctx, const Configuration& q0, const Configuration& q1, ThreadScratch& t,
                          std::string* message = nullptr, Failure* failure = nullptr);

/// @brief OMPL state validity checker for the context's mode.
class ValidityChecker : public ompl::base::StateValidityChecker {
 public:
  ValidityChecker(const ompl::base::SpaceInformationPtr& si, std::shared_ptr<const Context> ctx);
  bool isValid(const ompl::base::State* state) const override;
  /// @brief Clearance from the distance field (m) of the state's shape; 0 if invalid.
  double clearance(const ompl::base::State* state) const override;

 private:
  std::shared_ptr<const Context> ctx_;
  const CtrStateSpace* space_;
};

/// @brief OMPL motion validator that walks every motion forward from its source (never end-first or bisection:
/// the equilibrium branch and the friction band depend on the direction of travel).
class ForwardMotionValidator : public ompl::base::MotionValidator {
 public:
  ForwardMotionValidator(const ompl::base::SpaceInformationPtr& si, std::shared_ptr<const Context> ctx);
  bool checkMotion(const ompl::base::State* s1, const ompl::base::State* s2) const override;
  bool checkMotion(const ompl::base::State* s1, const ompl::base::State* s2,
                   std::pair<ompl::base::State*, double>& lastValid) const override;

 private:
  std::shared_ptr<const Context> ctx_;
  const CtrStateSpace* space_;
};

}  // namespace ctr::planner
