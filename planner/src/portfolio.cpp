#include "ctr/planner/portfolio.hpp"

#include <ompl/tools/multiplan/ParallelPlan.h>

#include <stdexcept>
#include <string>

namespace ob = ompl::base;

namespace ctr::planner {

namespace {
std::string memberNames(const std::vector<ob::PlannerPtr>& members) {
  std::string s = "Portfolio(";
  for (std::size_t i = 0; i < members.size(); ++i) s += (i ? "+" : "") + (members[i] ? members[i]->getName() : "?");
  return s + ")";
}
}  // namespace

Portfolio::Portfolio(const ob::SpaceInformationPtr& si, std::vector<ob::PlannerPtr> members)
    : ob::Planner(si, memberNames(members)), members_(std::move(members)) {
  if (members_.empty()) throw std::invalid_argument("Portfolio: no member planner");
  for (const auto& m : members_)
    if (!m || m->getSpaceInformation() != si)
      throw std::invalid_argument("Portfolio: every member must plan in the portfolio's SpaceInformation");
}

void Portfolio::setup() {
  ob::Planner::setup();
  for (auto& m : members_) {
    m->setProblemDefinition(pdef_);
    if (!m->isSetup()) m->setup();
  }
}

void Portfolio::clear() {
  ob::Planner::clear();
  for (auto& m : members_) m->clear();
}

ob::PlannerStatus Portfolio::solve(const ob::PlannerTerminationCondition& ptc) {
  checkValidity();
  ompl::tools::ParallelPlan pp(pdef_);
  for (auto& m : members_) {
    m->setProblemDefinition(pdef_);
    pp.addPlanner(m);
  }
  // No hybridisation (control paths cannot be hybridised): the first exact solution stops the others.
  return pp.solve(ptc, 1, members_.size(), false);
}

void Portfolio::getPlannerData(ob::PlannerData& data) const {
  for (const auto& m : members_) m->getPlannerData(data);
}

}  // namespace ctr::planner
