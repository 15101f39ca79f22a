// Plans a query file in ~10 lines with the SimpleSetup-like facade: planning_app QUERY.yaml
#include <ctr/planner/planner.hpp>
#include <iostream>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: planning_app QUERY.yaml\n";
    return 2;
  }
  ctr::planner::CtrPlanner planner(ctr::planner::loadQuery(argv[1]));  // robot, anatomy, OMPL set-up
  const ctr::planner::PlanResult r = planner.solve();                  // plan, then replay with friction
  std::cout << (r.solved ? "solved" : "not solved: " + r.message) << ": " << r.path.size() << " waypoints, tip error "
            << r.replay.tip_error * 1e3 << " mm, min clearance " << r.replay.min_clearance * 1e3 << " mm\n";
  return r.solved ? 0 : 1;
}
