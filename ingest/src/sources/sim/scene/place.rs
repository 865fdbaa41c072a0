//! Placing objects along the roads and at junctions without overlaps, and what the ground is
//! at a point.

use super::*;

pub(super) struct Placer<'a> {
    pub(super) grid: &'a SegmentGrid,
    pub(super) net: &'a RoadNetwork,
    pub(super) sides: &'a [RoadSides],
    pub(super) occ: Occupancy,
    pub(super) objects: Vec<SimObject>,
    pub(super) prims: Vec<Prim>,
    pub(super) max_objects: usize,
}

impl Placer<'_> {
    pub(super) fn surface(&self, p: [f64; 2]) -> Surface {
        surface_at(self.grid, self.net, self.sides, p)
    }

    /// Places `kind` at ground position `c` facing `yaw` if its footprint is on `on` and free.
    pub(super) fn try_place(
        &mut self,
        kind: Kind,
        c: [f64; 2],
        yaw: f64,
        on: &[Surface],
        rng: &mut ChaCha8Rng,
    ) -> Option<usize> {
        let (parts, fp) = parts(kind, rng);
        self.place_parts(kind, c, yaw, on, parts, fp, 0.0, rng)
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn place_parts(
        &mut self,
        kind: Kind,
        c: [f64; 2],
        yaw: f64,
        on: &[Surface],
        parts: Parts,
        fp: [f64; 2],
        lift: f64,
        rng: &mut ChaCha8Rng,
    ) -> Option<usize> {
        if self.objects.len() >= self.max_objects {
            return None;
        }
        let print = Footprint {
            c,
            half: [fp[0] / 2.0, fp[1] / 2.0],
            yaw,
        };
        if !on.is_empty()
            && !print
                .samples()
                .iter()
                .all(|p| on.contains(&self.surface(*p)))
        {
            return None;
        }
        // things lifted off the ground (tree crowns) may overhang others
        if lift <= 0.0 {
            if !self.occ.free(&print) {
                return None;
            }
            self.occ.insert(print);
        }
        let pose = Pose::from_parts(
            Vector::new(c[0] as f32, 0.0, c[1] as f32),
            Rotation::from_rotation_y(yaw as f32),
        );
        let index = self.objects.len() as u32;
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for (shape, at) in &parts {
            let local = Pose::from_translation(Vector::new(
                at[0] as f32,
                (at[1] - lift) as f32,
                at[2] as f32,
            ));
            let la = shape.as_shape().compute_aabb(&local);
            for k in 0..3 {
                lo[k] = lo[k].min(f64::from(la.mins[k]));
                hi[k] = hi[k].max(f64::from(la.maxs[k]));
            }
            self.prims.push(Prim {
                shape: *shape,
                pose: pose * local,
                object: index,
            });
        }
        let mid = [
            (lo[0] + hi[0]) / 2.0,
            (lo[1] + hi[1]) / 2.0,
            (lo[2] + hi[2]) / 2.0,
        ];
        let (s, co) = yaw.sin_cos();
        let attributes = Attributes::draw(kind, rng);
        let caption = attributes.caption(kind, 0, None);
        self.objects.push(SimObject {
            id: index + 1,
            kind,
            caption,
            attributes,
            center: [
                c[0] + co * mid[0] + s * mid[2],
                mid[1],
                c[1] - s * mid[0] + co * mid[2],
            ],
            size: [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]],
            yaw_rad: yaw,
        });
        Some(index as usize)
    }

    /// A tree: a trunk object and a crown object above it.
    pub(super) fn place_tree(&mut self, c: [f64; 2], on: &[Surface], rng: &mut ChaCha8Rng) {
        let (trunk, fp) = parts(Kind::Trunk, rng);
        let h = match trunk[0].0 {
            PrimShape::Cylinder(cy) => 2.0 * f64::from(cy.half_height),
            _ => 3.0,
        };
        let yaw = rng.random_range(0.0..std::f64::consts::TAU);
        if self
            .place_parts(Kind::Trunk, c, yaw, on, trunk, fp, 0.0, rng)
            .is_none()
        {
            return;
        }
        let rad = rng.random_range(1.4..2.8);
        let crown = vec![(ball(rad), [0.0, -rad * 0.8, 0.0])];
        self.place_parts(
            Kind::TreeCrown,
            c,
            yaw,
            &[],
            crown,
            [2.0 * rad, 2.0 * rad],
            h,
            rng,
        );
    }

    /// A traffic sign: its post (a pole) and the plate on top, facing `yaw`.
    pub(super) fn place_sign(
        &mut self,
        c: [f64; 2],
        yaw: f64,
        on: &[Surface],
        rng: &mut ChaCha8Rng,
    ) {
        let post = vec![(cylinder(0.05, 2.4), [0.0, -1.2, 0.0])];
        if self
            .place_parts(Kind::Pole, c, yaw, on, post, [0.3, 0.3], 0.0, rng)
            .is_none()
        {
            return;
        }
        let plate = vec![(cuboid(0.65, 0.65, 0.04), [0.0, -0.33, 0.0])];
        self.place_parts(Kind::TrafficSign, c, yaw, &[], plate, [0.65, 0.1], 2.4, rng);
    }
}

/// What the ground is at `p`.
pub(super) fn surface_at(
    grid: &SegmentGrid,
    net: &RoadNetwork,
    sides: &[RoadSides],
    p: [f64; 2],
) -> Surface {
    let mut best = Surface::Terrain;
    for &(r, s) in grid.cell(p) {
        let road = &net.roads[r as usize];
        let (d, side) = segment_distance(
            p,
            road.centerline[s as usize],
            road.centerline[s as usize + 1],
        );
        let half = road.width_m / 2.0;
        let park = if sides[r as usize].parking[side] {
            PARKING_M
        } else {
            0.0
        };
        let here = if d < half {
            Surface::Road
        } else if d < half + park {
            Surface::Parking
        } else if d < half + park + SIDEWALK_M {
            Surface::Sidewalk
        } else {
            Surface::Terrain
        };
        best = best.min(here);
    }
    best
}

/// Arc length at every vertex of a polyline.
pub(super) fn cumulative_lengths(c: &[[f64; 2]]) -> Vec<f64> {
    let mut cum = Vec::with_capacity(c.len());
    let mut acc = 0.0;
    cum.push(acc);
    for w in c.windows(2) {
        acc += dist(w[0], w[1]);
        cum.push(acc);
    }
    cum
}

/// Position and unit direction at arc length `t` along a polyline with cumulative lengths.
pub(super) fn at_length(c: &[[f64; 2]], cum: &[f64], t: f64) -> ([f64; 2], [f64; 2]) {
    let i = cum.partition_point(|x| *x <= t).clamp(1, c.len() - 1) - 1;
    let (a, b) = (c[i], c[i + 1]);
    let l = (cum[i + 1] - cum[i]).max(1e-9);
    let f = ((t - cum[i]) / l).clamp(0.0, 1.0);
    let d = [(b[0] - a[0]) / l, (b[1] - a[1]) / l];
    ([a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f], d)
}

pub(super) fn yaw_of(d: [f64; 2]) -> f64 {
    d[0].atan2(d[1])
}

/// Everything along one road: parked vehicles, street furniture, trees, people, fences,
/// hedges, buildings, billboards and playgrounds, on both sides.
pub(super) fn place_along_road(p: &mut Placer<'_>, ri: usize, rng: &mut ChaCha8Rng) {
    let road = p.net.roads[ri].clone();
    let c = &road.centerline;
    let cum = cumulative_lengths(c);
    let len = *cum.last().unwrap_or(&0.0);
    let half = road.width_m / 2.0;
    let margin = 12.0;
    if len < 2.0 * margin {
        return;
    }
    for side in 0..2usize {
        // offset direction: right of travel is (d.z, -d.x); left is the opposite
        let sgn = if side == 0 { 1.0 } else { -1.0 };
        let park = if p.sides[ri].parking[side] {
            PARKING_M
        } else {
            0.0
        };
        let curb = half + park;
        let at = |t: f64, off: f64| {
            let (q, d) = at_length(c, &cum, t);
            let right = [d[1] * sgn, -d[0] * sgn];
            ([q[0] + right[0] * off, q[1] + right[1] * off], d, right)
        };
        // parked vehicles in the parking lane, nose in the direction of travel on that side
        if park > 0.0 {
            let mut t = margin + rng.random_range(0.0..4.0);
            while t < len - margin {
                let roll = rng.random_range(0.0..1.0);
                let kind = if roll < 0.68 {
                    Some(Kind::Car)
                } else if roll < 0.74 {
                    Some(Kind::OtherVehicle)
                } else if roll < 0.78 {
                    Some(Kind::Truck)
                } else if roll < 0.82 {
                    Some(Kind::ParkedTrailer)
                } else if roll < 0.86 {
                    Some(Kind::Motorcycle)
                } else {
                    None
                };
                let (q, d, _) = at(t, half + park / 2.0);
                let fwd = if side == 0 { d } else { [-d[0], -d[1]] };
                let mut step = 7.0;
                if let Some(k) = kind
                    && p.try_place(k, q, yaw_of(fwd), &[Surface::Parking], rng)
                        .is_some()
                {
                    step = p.objects.last().map_or(7.0, |o| o.size[2]) + rng.random_range(0.8..3.0);
                }
                t += step;
            }
        }
        // sidewalk, near the curb: lamps, trees, poles, signs, hydrants, bins, mailboxes
        let mut t = margin + rng.random_range(0.0..6.0);
        let mut since_lamp = 100.0;
        while t < len - margin {
            let (q, d, right) = at(t, curb + 0.6);
            let facing_road = yaw_of([-right[0], -right[1]]);
            let on = [Surface::Sidewalk];
            let roll = rng.random_range(0.0..1.0);
            if since_lamp > 28.0 {
                // the lamp's arm (local -x) reaches over the road: local +x, which is
                // (cos yaw, -sin yaw), points away from it
                let yaw = (-right[1]).atan2(right[0]);
                if p.try_place(Kind::StreetLamp, q, yaw, &on, rng).is_some() {
                    since_lamp = 0.0;
                }
            } else if roll < 0.45 {
                p.place_tree(q, &on, rng);
            } else if roll < 0.55 {
                p.try_place(Kind::Pole, q, 0.0, &on, rng);
            } else if roll < 0.63 {
                // the plate faces oncoming traffic on this side
                let toward = if side == 0 { [-d[0], -d[1]] } else { d };
                p.place_sign(q, yaw_of(toward), &on, rng);
            } else if roll < 0.70 {
                p.try_place(Kind::FireHydrant, q, facing_road, &on, rng);
            } else if roll < 0.80 {
                p.try_place(Kind::TrashCan, q, facing_road, &on, rng);
            } else if roll < 0.86 {
                p.try_place(Kind::Mailbox, q, facing_road, &on, rng);
            }
            let step = rng.random_range(5.0..9.0);
            since_lamp += step;
            t += step;
        }
        // sidewalk, back half: benches, bus stops, parked bicycles, people
        let mut t = margin + rng.random_range(0.0..10.0);
        while t < len - margin {
            let roll = rng.random_range(0.0..1.0);
            let on = [Surface::Sidewalk];
            let (q, d, right) = at(t, curb + 2.0);
            let facing_road = yaw_of([-right[0], -right[1]]);
            if roll < 0.10 {
                let (q, _, _) = at(t, curb + 2.1);
                p.try_place(Kind::BusStopShelter, q, facing_road, &on, rng);
            } else if roll < 0.30 {
                p.try_place(Kind::Bench, q, facing_road, &on, rng);
            } else if roll < 0.50 {
                p.try_place(
                    Kind::Bicycle,
                    q,
                    yaw_of(d) + rng.random_range(-0.3..0.3),
                    &on,
                    rng,
                );
            } else if roll < 0.85 {
                let (q, _, _) = at(t, curb + rng.random_range(0.8..2.4));
                let dir = if rng.random_range(0..2) == 0 {
                    d
                } else {
                    [-d[0], -d[1]]
                };
                p.try_place(Kind::Person, q, yaw_of(dir), &on, rng);
            }
            t += rng.random_range(6.0..16.0);
        }
        // beyond the sidewalk: fences or hedges at the property line, then buildings set
        // back from it, with the odd billboard or playground in a gap
        let line = curb + SIDEWALK_M + 0.5;
        let mut t = margin;
        while t < len - margin {
            let (q, d, _) = at(t, line);
            let roll = rng.random_range(0.0..1.0);
            if roll < 0.3 {
                // fence parallel to the road: its length is local x, so yaw = road heading
                p.try_place(
                    Kind::Fence,
                    q,
                    yaw_of(d) + std::f64::consts::FRAC_PI_2,
                    &[Surface::Terrain],
                    rng,
                );
            } else if roll < 0.5 {
                p.try_place(
                    Kind::Hedge,
                    q,
                    yaw_of(d) + std::f64::consts::FRAC_PI_2,
                    &[Surface::Terrain],
                    rng,
                );
            }
            t += rng.random_range(10.0..22.0);
        }
        let mut t = margin;
        while t < len - margin {
            let roll = rng.random_range(0.0..1.0);
            let setback = rng.random_range(2.5..8.0);
            let kind = if roll < 0.04 {
                Kind::Billboard
            } else if roll < 0.07 {
                Kind::Playground
            } else if roll < 0.85 {
                Kind::Building
            } else {
                // a garden: a tree set back from the road
                let (q, _, _) = at(t, line + setback + 2.0);
                p.place_tree(q, &[Surface::Terrain], rng);
                t += 8.0;
                continue;
            };
            let (parts_v, fp) = parts(kind, rng);
            let depth = fp[1];
            let (q, _, right) = at(t + fp[0] / 2.0, line + 1.0 + setback + depth / 2.0);
            let facing_road = yaw_of([-right[0], -right[1]]);
            // the front (local +z) faces the road; width runs along it
            let placed = p
                .place_parts(
                    kind,
                    q,
                    facing_road,
                    &[Surface::Terrain],
                    parts_v,
                    fp,
                    0.0,
                    rng,
                )
                .is_some();
            t += if placed {
                fp[0] + rng.random_range(1.0..6.0)
            } else {
                4.0
            };
        }
    }
}

/// A traffic light on the right-hand sidewalk of each road arriving at a crossroads or
/// T-junction, a little before the junction, facing the arriving traffic.
pub(super) fn place_traffic_lights(p: &mut Placer<'_>, rng: &mut ChaCha8Rng) {
    use crate::sources::sim::roads::JunctionKind;
    for ri in 0..p.net.roads.len() {
        let road = p.net.roads[ri].clone();
        let c = &road.centerline;
        let cum = cumulative_lengths(c);
        let len = *cum.last().unwrap_or(&0.0);
        for (node, toward_b) in [(road.b, true), (road.a, false)] {
            if !matches!(
                p.net.nodes[node].kind,
                JunctionKind::Crossroads | JunctionKind::TJunction
            ) || len < 30.0
            {
                continue;
            }
            let t = if toward_b { len - 9.0 } else { 9.0 };
            let (q, d) = at_length(c, &cum, t);
            let travel = if toward_b { d } else { [-d[0], -d[1]] };
            let side = if toward_b { 0 } else { 1 };
            let park = if p.sides[ri].parking[side] {
                PARKING_M
            } else {
                0.0
            };
            let off = road.width_m / 2.0 + park + 0.5;
            let right = [travel[1], -travel[0]];
            let pos = [q[0] + right[0] * off, q[1] + right[1] * off];
            let facing = yaw_of([-travel[0], -travel[1]]);
            p.try_place(Kind::TrafficLight, pos, facing, &[Surface::Sidewalk], rng);
        }
    }
}
