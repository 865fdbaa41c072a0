//! The only unsafe boundary of the planner: a cxx bridge to `shim/ompl_shim.cc`.
//!
//! C++ calls back into Rust for every state validity check through [`Checker`].
#![allow(unsafe_code)]
#![allow(missing_debug_implementations)]

/// Validity callback handed to OMPL. Holds a boxed Rust closure.
pub struct Checker {
    pub(crate) f: Box<dyn Fn(f64, f64, f64) -> bool>,
}

impl Checker {
    fn is_valid(&self, x: f64, y: f64, yaw: f64) -> bool {
        (self.f)(x, y, yaw)
    }
}

#[cxx::bridge(namespace = "og")]
pub(crate) mod bridge {
    /// The car's state space and how paths in it are checked and sampled, shared by both
    /// requests: Reeds-Shepp (reverse allowed) or Dubins curves of `turning_radius` metres
    /// within the ground bounds, valid states asked of the [`Checker`] every `check_step_m`
    /// along a motion, the answer's poses every `sample_step` metres, OMPL seeded once with
    /// `seed`.
    #[derive(Clone, Copy)]
    struct CarSpace {
        min_x: f64,
        min_y: f64,
        max_x: f64,
        max_y: f64,
        turning_radius: f64,
        reverse_allowed: bool,
        check_step_m: f64,
        sample_step: f64,
        seed: u32,
    }

    /// One SE(2) planning problem.
    struct PlanRequest {
        space: CarSpace,
        start_x: f64,
        start_y: f64,
        start_yaw: f64,
        goal_x: f64,
        goal_y: f64,
        goal_yaw: f64,
        budget_secs: f64,
        goal_tolerance: f64,
        range: f64,
        cost_threshold: f64,
    }

    /// Poses to follow: `lanes` poses (flattened x, y, yaw triples) at each station along
    /// the route, the route's own first and then its lateral offsets; the start is the first
    /// station's first pose and the goal the last's. From each reached pose, one curve of the
    /// car's space goes to a pose at the farthest of the next `max_skip` stations that it
    /// reaches through valid states (depth first, so a dead end is backed out of); the search
    /// gives up after `limit_secs`.
    struct FollowRequest {
        space: CarSpace,
        poses: Vec<f64>,
        lanes: u32,
        limit_secs: f64,
        max_skip: u32,
    }

    /// What OMPL found: poses flattened as x, y, yaw triples.
    struct PlanResult {
        solved: bool,
        exact: bool,
        planner: String,
        poses: Vec<f64>,
        length: f64,
    }

    extern "Rust" {
        type Checker;
        fn is_valid(self: &Checker, x: f64, y: f64, yaw: f64) -> bool;
    }

    unsafe extern "C++" {
        include!("planner/shim/ompl_shim.h");
        fn plan_se2(req: &PlanRequest, checker: &Checker) -> PlanResult;
        fn follow_se2(req: &FollowRequest, checker: &Checker) -> PlanResult;
    }
}
