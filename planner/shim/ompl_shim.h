// C++ side of the planner's OMPL bridge: two functions over OMPL's SE(2) car spaces (Reeds-Shepp
// or Dubins) that ask Rust whether each state is valid: one follows given poses with OMPL's
// curves, one plans with RRT*.
#pragma once
#include "rust/cxx.h"
#include <memory>

namespace og {
struct PlanRequest;
struct PlanResult;
struct FollowRequest;
struct Checker;
PlanResult plan_se2(const PlanRequest &req, const Checker &checker);
PlanResult follow_se2(const FollowRequest &req, const Checker &checker);
} // namespace og
