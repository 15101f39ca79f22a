/// @file portfolio.hpp
/// @brief A planner that runs several OMPL planners on the same problem concurrently (ompl::tools::ParallelPlan)
/// and stops all of them at the first exact solution: tree planners with different biases (RRT, KPIECE) solve
/// different queries, and a portfolio solves what either solves on a multi-core machine.
#pragma once

#include <ompl/base/Planner.h>

#include <vector>

namespace ctr::planner {

/// @brief OMPL planner running its members concurrently on one problem definition; the first exact solution
/// ends the solve. Members must share this planner's SpaceInformation; validity checking must be thread-safe
/// (it is in ctr: per-thread model workspaces). With a CPU-time termination condition the members' CPU time adds
/// up (two members use the budget twice as fast in wall-clock terms).
class Portfolio : public ompl::base::Planner {
 public:
  Portfolio(const ompl::base::SpaceInformationPtr& si, std::vector<ompl::base::PlannerPtr> members);
  ompl::base::PlannerStatus solve(const ompl::base::PlannerTerminationCondition& ptc) override;
  void clear() override;
  void setup() override;
  void getPlannerData(ompl::base::PlannerData& data) const override;
  const std::vector<ompl::base::PlannerPtr>& members() const { return members_; }

 private:
  std::vector<ompl::base::PlannerPtr> members_;
};

}  // namespace ctr::planner
