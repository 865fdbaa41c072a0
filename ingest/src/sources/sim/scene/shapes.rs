//! The parry shapes objects are built of: primitives placed in the world and each kind's
//! local parts.

use super::*;

/// A primitive shape of an object.
#[derive(Debug, Clone, Copy)]
pub enum PrimShape {
    /// Box with half extents.
    Cuboid(Cuboid),
    /// Vertical cylinder.
    Cylinder(Cylinder),
    /// Sphere.
    Ball(Ball),
}

impl PrimShape {
    pub(super) fn as_shape(&self) -> &dyn Shape {
        match self {
            PrimShape::Cuboid(s) => s,
            PrimShape::Cylinder(s) => s,
            PrimShape::Ball(s) => s,
        }
    }

    pub(super) fn cast(&self, pose: &Pose, ray: &Ray, max: f32) -> Option<f32> {
        match self {
            PrimShape::Cuboid(s) => s.cast_ray(pose, ray, max, true),
            PrimShape::Cylinder(s) => s.cast_ray(pose, ray, max, true),
            PrimShape::Ball(s) => s.cast_ray(pose, ray, max, true),
        }
    }
}

/// A primitive placed in the world.
#[derive(Debug, Clone, Copy)]
pub struct Prim {
    /// The shape.
    pub shape: PrimShape,
    /// Its world pose.
    pub pose: Pose,
    /// Index of its object in [`City::objects`].
    pub object: u32,
}

/// Local-frame parts of an object: (shape, local centre [x, y, z]).
pub(super) type Parts = Vec<(PrimShape, [f64; 3])>;

pub(super) fn cuboid(w: f64, h: f64, l: f64) -> PrimShape {
    PrimShape::Cuboid(Cuboid::new(Vector::new(
        (w / 2.0) as f32,
        (h / 2.0) as f32,
        (l / 2.0) as f32,
    )))
}

pub(super) fn cylinder(radius: f64, h: f64) -> PrimShape {
    PrimShape::Cylinder(Cylinder::new((h / 2.0) as f32, radius as f32))
}

pub(super) fn ball(radius: f64) -> PrimShape {
    PrimShape::Ball(Ball::new(radius as f32))
}

/// Shapes of an object standing on the ground (y up is negative), footprint `[w, l]`.
pub(super) fn parts(kind: Kind, rng: &mut ChaCha8Rng) -> (Parts, [f64; 2]) {
    let r = |rng: &mut ChaCha8Rng, a: f64, b: f64| rng.random_range(a..b);
    match kind {
        Kind::Car => {
            let (w, l, h) = (r(rng, 1.7, 1.9), r(rng, 3.9, 4.8), r(rng, 1.4, 1.6));
            let body = 0.6;
            let cab = h - 0.2 - body;
            (
                vec![
                    (cuboid(w, body, l), [0.0, -(0.2 + body / 2.0), 0.0]),
                    (
                        cuboid(w * 0.9, cab, l * 0.55),
                        [0.0, -(0.2 + body + cab / 2.0), -l * 0.05],
                    ),
                ],
                [w, l],
            )
        }
        Kind::Truck => {
            let (w, l, h) = (2.4, r(rng, 6.5, 9.0), r(rng, 3.0, 3.6));
            (
                vec![
                    (
                        cuboid(w, h - 0.5, l - 2.2),
                        [0.0, -(0.5 + (h - 0.5) / 2.0), -1.1],
                    ),
                    (cuboid(w, 2.4, 2.0), [0.0, -(0.5 + 1.2), l / 2.0 - 1.0]),
                ],
                [w, l],
            )
        }
        Kind::OtherVehicle => {
            let (w, l, h) = (2.0, r(rng, 5.0, 6.2), r(rng, 2.1, 2.7));
            (
                vec![(
                    cuboid(w, h - 0.25, l),
                    [0.0, -(0.25 + (h - 0.25) / 2.0), 0.0],
                )],
                [w, l],
            )
        }
        Kind::ParkedTrailer => {
            let (w, l, h) = (r(rng, 1.6, 2.1), r(rng, 2.5, 4.5), r(rng, 1.2, 2.4));
            (
                vec![
                    (
                        cuboid(w, h - 0.45, l),
                        [0.0, -(0.45 + (h - 0.45) / 2.0), 0.0],
                    ),
                    (cuboid(0.15, 0.15, 1.2), [0.0, -0.5, l / 2.0 + 0.6]),
                ],
                [w, l + 1.2],
            )
        }
        Kind::Bicycle => (
            vec![
                (cuboid(0.08, 0.66, 0.66), [0.0, -0.33, 0.52]),
                (cuboid(0.08, 0.66, 0.66), [0.0, -0.33, -0.52]),
                (cuboid(0.1, 0.35, 1.0), [0.0, -0.8, 0.0]),
                (cuboid(0.55, 0.05, 0.05), [0.0, -1.0, 0.45]),
            ],
            [0.55, 1.75],
        ),
        Kind::Motorcycle => (
            vec![
                (cuboid(0.15, 0.6, 0.6), [0.0, -0.3, 0.7]),
                (cuboid(0.15, 0.6, 0.6), [0.0, -0.3, -0.7]),
                (cuboid(0.5, 0.5, 1.3), [0.0, -0.8, 0.0]),
                (cuboid(0.75, 0.06, 0.06), [0.0, -1.15, 0.55]),
            ],
            [0.75, 2.0],
        ),
        Kind::Person => {
            let h = r(rng, 1.55, 1.9);
            let head = 0.11;
            let body = h - 2.0 * head;
            (
                vec![
                    (cylinder(0.2, body), [0.0, -body / 2.0, 0.0]),
                    (ball(head), [0.0, -(body + head), 0.0]),
                ],
                [0.45, 0.45],
            )
        }
        Kind::Building => {
            let (w, l, h) = (r(rng, 10.0, 24.0), r(rng, 9.0, 18.0), r(rng, 6.0, 24.0));
            let mut v = vec![(cuboid(w, h, l), [0.0, -h / 2.0, 0.0])];
            if rng.random_range(0.0..1.0) < 0.4 {
                // a penthouse or roof structure
                let (rw, rl, rh) = (w * 0.4, l * 0.4, r(rng, 2.0, 4.0));
                v.push((cuboid(rw, rh, rl), [0.0, -(h + rh / 2.0), 0.0]));
            }
            (v, [w, l])
        }
        Kind::Fence => {
            let (l, h) = (r(rng, 8.0, 20.0), r(rng, 1.0, 1.9));
            (vec![(cuboid(l, h, 0.08), [0.0, -h / 2.0, 0.0])], [l, 0.3])
        }
        Kind::Hedge => {
            let (l, h, w) = (r(rng, 3.0, 9.0), r(rng, 0.8, 1.6), r(rng, 0.7, 1.3));
            (vec![(cuboid(l, h, w), [0.0, -h / 2.0, 0.0])], [l, w])
        }
        Kind::Trunk => {
            // the height is stored for the crown: see `place_tree`
            let (rad, h) = (r(rng, 0.12, 0.28), r(rng, 2.2, 3.6));
            (vec![(cylinder(rad, h), [0.0, -h / 2.0, 0.0])], [0.6, 0.6])
        }
        Kind::TreeCrown => {
            // normally placed with its trunk, see `place_tree`
            let rad = r(rng, 1.4, 2.8);
            (vec![(ball(rad), [0.0, -rad, 0.0])], [2.0 * rad, 2.0 * rad])
        }
        Kind::Pole => {
            let h = r(rng, 6.0, 9.0);
            (vec![(cylinder(0.12, h), [0.0, -h / 2.0, 0.0])], [0.4, 0.4])
        }
        Kind::TrafficSign => {
            // normally placed on its post, see `place_sign`
            (
                vec![(cuboid(0.65, 0.65, 0.04), [0.0, -0.33, 0.0])],
                [0.65, 0.1],
            )
        }
        Kind::StreetLamp => {
            let h = r(rng, 6.5, 9.0);
            (
                vec![
                    (cylinder(0.1, h), [0.0, -h / 2.0, 0.0]),
                    // the arm reaches over the road: local -x
                    (cuboid(1.6, 0.08, 0.08), [-0.8, -(h - 0.1), 0.0]),
                    (cuboid(0.6, 0.15, 0.3), [-1.5, -(h - 0.25), 0.0]),
                ],
                [0.5, 0.5],
            )
        }
        Kind::TrafficLight => (
            vec![
                (cylinder(0.09, 3.2), [0.0, -1.6, 0.0]),
                (cuboid(0.35, 0.95, 0.3), [0.0, -(3.2 + 0.475), 0.0]),
            ],
            [0.45, 0.45],
        ),
        Kind::Bench => {
            let l = r(rng, 1.5, 2.2);
            (
                vec![
                    (cuboid(l, 0.45, 0.5), [0.0, -0.225, 0.0]),
                    (cuboid(l, 0.45, 0.06), [0.0, -0.67, -0.22]),
                ],
                [l, 0.6],
            )
        }
        Kind::BusStopShelter => {
            let l = r(rng, 3.5, 5.0);
            (
                vec![
                    (cuboid(l, 0.1, 1.6), [0.0, -2.45, 0.0]),
                    (cuboid(l, 2.3, 0.05), [0.0, -1.25, -0.75]),
                    (cuboid(0.05, 2.3, 1.4), [-l / 2.0, -1.25, 0.0]),
                    (cuboid(0.05, 2.3, 1.4), [l / 2.0, -1.25, 0.0]),
                    (cuboid(l * 0.7, 0.45, 0.4), [0.0, -0.225, -0.45]),
                ],
                [l, 1.6],
            )
        }
        Kind::FireHydrant => (
            vec![
                (cylinder(0.15, 0.65), [0.0, -0.325, 0.0]),
                (ball(0.14), [0.0, -0.7, 0.0]),
            ],
            [0.4, 0.4],
        ),
        Kind::TrashCan => {
            let h = r(rng, 0.8, 1.1);
            (vec![(cylinder(0.3, h), [0.0, -h / 2.0, 0.0])], [0.6, 0.6])
        }
        Kind::Mailbox => (
            vec![
                (cylinder(0.06, 0.9), [0.0, -0.45, 0.0]),
                (cuboid(0.45, 0.6, 0.4), [0.0, -1.2, 0.0]),
            ],
            [0.45, 0.4],
        ),
        Kind::Billboard => {
            let (w, h, lift) = (r(rng, 5.0, 8.0), r(rng, 2.5, 3.5), r(rng, 2.5, 4.5));
            (
                vec![
                    (cuboid(w, h, 0.25), [0.0, -(lift + h / 2.0), 0.0]),
                    (cylinder(0.18, lift), [-w / 3.0, -lift / 2.0, 0.0]),
                    (cylinder(0.18, lift), [w / 3.0, -lift / 2.0, 0.0]),
                ],
                [w, 0.6],
            )
        }
        Kind::Playground => (
            vec![
                (cuboid(3.0, 2.6, 3.0), [-2.5, -1.3, 0.0]),
                (cuboid(0.7, 1.6, 3.5), [0.0, -0.8, 1.0]),
                (cuboid(3.5, 0.15, 0.15), [2.8, -2.3, -1.0]),
                (cylinder(0.08, 2.3), [1.1, -1.15, -1.0]),
                (cylinder(0.08, 2.3), [4.5, -1.15, -1.0]),
            ],
            [10.0, 7.0],
        ),
    }
}
