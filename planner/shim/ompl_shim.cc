#include "planner/shim/ompl_shim.h"
#include "planner/src/ffi.rs.h"

#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/ScopedState.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/base/spaces/DubinsStateSpace.h>
#include <ompl/base/spaces/ReedsSheppStateSpace.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <chrono>
#include <mutex>

namespace og {

namespace ob = ompl::base;
namespace ogeo = ompl::geometric;

PlanResult plan_se2(const PlanRequest &req, const Checker &checker) {
  static std::once_flag once;
  std::call_once(once, [&] {
    ompl::msg::setLogLevel(ompl::msg::LOG_NONE);
    // OMPL takes one seed per process, before its first random number generator
    ompl::RNG::setSeed(req.seed);
  });
  PlanResult out;
  out.solved = false;
  out.exact = false;
  out.length = 0.0;
  ob::StateSpacePtr space;
  if (req.reverse_allowed) {
    space = std::make_shared<ob::ReedsSheppStateSpace>(req.turning_radius);
    out.planner = "RRTstar/ReedsShepp";
  } else {
    space = std::make_shared<ob::DubinsStateSpace>(req.turning_radius);
    out.planner = "RRTstar/Dubins";
  }
  ob::RealVectorBounds bounds(2);
  bounds.setLow(0, req.min_x);
  bounds.setLow(1, req.min_y);
  bounds.setHigh(0, req.max_x);
  bounds.setHigh(1, req.max_y);
  space->as<ob::SE2StateSpace>()->setBounds(bounds);

  ogeo::SimpleSetup ss(space);
  // OMPL's motion validator calls only this checker, so it must enforce bounds itself (the
  // Rust side does).
  ss.setStateValidityChecker([&checker](const ob::State *s) {
    const auto *st = s->as<ob::SE2StateSpace::StateType>();
    return checker.is_valid(st->getX(), st->getY(), st->getYaw());
  });
  // an absolute step along motions, whatever the size of the space
  ss.getSpaceInformation()->setStateValidityCheckingResolution(
      std::min(1.0, req.check_step_m / space->getMaximumExtent()));
  ob::ScopedState<ob::SE2StateSpace> start(space), goal(space);
  start->setXY(req.start_x, req.start_y);
  start->setYaw(req.start_yaw);
  goal->setXY(req.goal_x, req.goal_y);
  goal->setYaw(req.goal_yaw);
  ss.setStartAndGoalStates(start, goal, req.goal_tolerance);
  auto si = ss.getSpaceInformation();
  auto objective = std::make_shared<ob::PathLengthOptimizationObjective>(si);
  // RRT* keeps optimizing until the path is this short (or the budget runs out)
  objective->setCostThreshold(ob::Cost(req.cost_threshold));
  ss.getProblemDefinition()->setOptimizationObjective(objective);
  auto planner = std::make_shared<ogeo::RRTstar>(si);
  planner->setRange(req.range);
  ss.setPlanner(planner);
  ss.setup();

  const auto t0 = std::chrono::steady_clock::now();
  ob::PlannerStatus status = ss.solve(ob::timedPlannerTerminationCondition(req.budget_secs));
  if (status != ob::PlannerStatus::EXACT_SOLUTION) {
    out.planner = status.asString();
    return out;
  }
  const double used =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // simplification keeps shortcutting while it has time, so give it a bounded share
  const double left = std::min(req.budget_secs - used, 0.25 * req.budget_secs);
  if (left > 0.0) {
    ss.simplifySolution(left);
  }
  auto &path = ss.getSolutionPath();
  out.length = path.length();
  path.interpolate(static_cast<unsigned int>(std::max(2.0, path.length() / req.sample_step)));
  for (std::size_t i = 0; i < path.getStateCount(); ++i) {
    const auto *st = path.getState(i)->as<ob::SE2StateSpace::StateType>();
    out.poses.push_back(st->getX());
    out.poses.push_back(st->getY());
    out.poses.push_back(st->getYaw());
  }
  out.solved = true;
  out.exact = true;
  return out;
}

} // namespace og
