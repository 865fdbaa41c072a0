// C++ side of the planner's OMPL bridge: one function that plans an SE(2) Reeds-Shepp path
// with RRT* and asks Rust whether each state is valid.
#pragma once
#include "rust/cxx.h"
#include <memory>

namespace og {
struct PlanRequest;
struct PlanResult;
struct Checker;
PlanResult plan_se2(const PlanRequest &req, const Checker &checker);
} // namespace og
