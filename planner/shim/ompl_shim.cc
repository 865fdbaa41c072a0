#include "planner/shim/ompl_shim.h"
#include "planner/src/ffi.rs.h"

#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/ScopedState.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/base/spaces/DubinsStateSpace.h>
#include <ompl/base/spaces/ReedsSheppStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <chrono>
#include <cstdint>
#include <mutex>
#include <vector>

namespace og {

namespace ob = ompl::base;
namespace ogeo = ompl::geometric;

namespace {

// Once per process, before OMPL's first random number generator: its log level and its seed.
void init(std::uint32_t seed) {
  static std::once_flag once;
  std::call_once(once, [&] {
    ompl::msg::setLogLevel(ompl::msg::LOG_NONE);
    ompl::RNG::setSeed(seed);
  });
}

// The car's state space: Reeds-Shepp (reverse allowed) or Dubins, within the bounds.
ob::StateSpacePtr car_space(const CarSpace &car) {
  ob::StateSpacePtr space;
  if (car.reverse_allowed) {
    space = std::make_shared<ob::ReedsSheppStateSpace>(car.turning_radius);
  } else {
    space = std::make_shared<ob::DubinsStateSpace>(car.turning_radius);
  }
  ob::RealVectorBounds bounds(2);
  bounds.setLow(0, car.min_x);
  bounds.setLow(1, car.min_y);
  bounds.setHigh(0, car.max_x);
  bounds.setHigh(1, car.max_y);
  space->as<ob::SE2StateSpace>()->setBounds(bounds);
  return space;
}

// The path's states, interpolated every sample_step along its curves, into out.poses.
void emit(ogeo::PathGeometric &path, double sample_step, PlanResult &out) {
  out.length = path.length();
  path.interpolate(static_cast<unsigned int>(std::max(2.0, path.length() / sample_step)));
  for (std::size_t i = 0; i < path.getStateCount(); ++i) {
    const auto *st = path.getState(i)->as<ob::SE2StateSpace::StateType>();
    out.poses.push_back(st->getX());
    out.poses.push_back(st->getY());
    out.poses.push_back(st->getYaw());
  }
  out.solved = true;
  out.exact = true;
}

// An unsolved result named `planner`, after seeding OMPL (once per process).
PlanResult unsolved(std::uint32_t seed, const char *planner) {
  init(seed);
  PlanResult out;
  out.solved = false;
  out.exact = false;
  out.length = 0.0;
  out.planner = planner;
  return out;
}

// Asks `checker` whether each state is valid, every `check_step_m` along a motion. OMPL's
// motion validator calls only this checker, so it must enforce bounds itself (the Rust side
// does).
void check_with(ob::SpaceInformation &si, const Checker &checker, double check_step_m) {
  si.setStateValidityChecker([&checker](const ob::State *s) {
    const auto *st = s->as<ob::SE2StateSpace::StateType>();
    return checker.is_valid(st->getX(), st->getY(), st->getYaw());
  });
  // an absolute step along motions, whatever the size of the space
  si.setStateValidityCheckingResolution(
      std::min(1.0, check_step_m / si.getStateSpace()->getMaximumExtent()));
}

} // namespace

PlanResult follow_se2(const FollowRequest &req, const Checker &checker) {
  PlanResult out =
      unsolved(req.space.seed,
               req.space.reverse_allowed ? "follow/ReedsShepp" : "follow/Dubins");
  const std::size_t lanes = req.lanes;
  const std::size_t n = lanes == 0 ? 0 : req.poses.size() / (3 * lanes);
  if (n < 2 || req.max_skip < 1) {
    return out;
  }
  const auto t0 = std::chrono::steady_clock::now();
  auto space = car_space(req.space);
  auto si = std::make_shared<ob::SpaceInformation>(space);
  check_with(*si, checker, req.space.check_step_m);
  si->setup();
  // node (i, k): station i along the route, lateral offset k (0 is the route itself)
  std::vector<ob::ScopedState<ob::SE2StateSpace>> states;
  states.reserve(n * lanes);
  for (std::size_t v = 0; v < n * lanes; ++v) {
    ob::ScopedState<ob::SE2StateSpace> s(space);
    s->setXY(req.poses[3 * v], req.poses[3 * v + 1]);
    s->setYaw(req.poses[3 * v + 2]);
    states.push_back(s);
  }
  // -1 unknown, 0 invalid or exhausted (no way on from it), 1 valid
  std::vector<signed char> mark(n * lanes, -1);
  auto usable = [&](std::size_t v) {
    if (mark[v] < 0) {
      mark[v] = si->isValid(states[v].get()) ? 1 : 0;
    }
    return mark[v] == 1;
  };
  if (!usable(0) || !usable((n - 1) * lanes)) {
    return out;
  }
  // depth first, farthest station first and the route before its offsets: from each node,
  // one curve to the farthest node within max_skip stations that it reaches through valid
  // states; a node with no way on is never tried again. The start and goal are offset 0.
  struct Frame {
    std::size_t v;
    std::size_t j;
    std::size_t k;
  };
  auto first_j = [&](std::size_t i) {
    return std::min(n - 1, i + static_cast<std::size_t>(req.max_skip));
  };
  std::vector<Frame> stack{{0, first_j(0), 0}};
  bool reached = false;
  std::size_t expansions = 0;
  while (!stack.empty() && !reached) {
    if (++expansions % 16 == 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() >
            req.limit_secs) {
      return out;
    }
    Frame &f = stack.back();
    const std::size_t i = f.v / lanes;
    if (f.j <= i) {
      mark[f.v] = 0;
      stack.pop_back();
      continue;
    }
    const std::size_t w = f.j * lanes + f.k;
    const std::size_t k_end = f.j == n - 1 ? 1 : lanes;
    if (++f.k >= k_end) {
      f.k = 0;
      --f.j;
    }
    if (!usable(w) || !si->checkMotion(states[f.v].get(), states[w].get())) {
      continue;
    }
    if (w == (n - 1) * lanes) {
      reached = true;
    }
    stack.push_back({w, first_j(w / lanes), 0});
  }
  if (!reached) {
    return out;
  }
  ogeo::PathGeometric path(si);
  for (const Frame &f : stack) {
    path.append(states[f.v].get());
  }
  emit(path, req.space.sample_step, out);
  return out;
}

PlanResult plan_se2(const PlanRequest &req, const Checker &checker) {
  PlanResult out =
      unsolved(req.space.seed,
               req.space.reverse_allowed ? "RRTstar/ReedsShepp" : "RRTstar/Dubins");
  auto space = car_space(req.space);

  ogeo::SimpleSetup ss(space);
  check_with(*ss.getSpaceInformation(), checker, req.space.check_step_m);
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
  emit(ss.getSolutionPath(), req.space.sample_step, out);
  return out;
}

} // namespace og
