//! The simulator's ground truth read back: `ground_truth/objects.json` (each object's box,
//! class, noun, colour and material), `roads.json` (roads and junctions) and `movers.json`
//! (the lines cars and walkers keep to), as [`super::generate`] writes them. The evaluations
//! (crate `og-eval`) score maps against it.

use std::path::Path;

use crate::error::{Error, Result};

pub use crate::error::{json_xy, read_json, read_text};

/// One ground-truth object of the simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthObject {
    /// Its id in `objects.json`.
    pub id: i64,
    /// Ground-plane centre (KITTI world x, z), metres.
    pub centre_xz: [f64; 2],
    /// Half the larger footprint side, metres.
    pub radius_m: f64,
    /// The simulator's class of the object (`objects.json` `class`: a SemanticKITTI class
    /// name or an open-vocabulary kind such as `bench`).
    pub class: String,
    /// True noun phrase.
    pub noun: String,
    /// True colour phrase (may be empty).
    pub colour: String,
    /// True material phrase (may be empty).
    pub material: String,
    /// Footprint corners on the ground plane (x, z), counter-clockwise or clockwise.
    pub footprint: [[f64; 2]; 4],
    /// Height range above the ground (bottom, top), metres.
    pub heights: (f64, f64),
}

/// Reads `DIR/ground_truth/objects.json`.
pub fn read_truth(sim_dir: &Path) -> Result<Vec<TruthObject>> {
    let path = sim_dir.join("ground_truth/objects.json");
    let v = read_json(&path)?;
    let bad = |d: String| Error::File {
        path: path.clone(),
        detail: d,
    };
    let objs = v["objects"]
        .as_array()
        .ok_or_else(|| bad("no \"objects\" array".into()))?;
    let mut out = Vec::with_capacity(objs.len());
    for (i, o) in objs.iter().enumerate() {
        let num = |p: &str| {
            o.pointer(p)
                .and_then(serde_json::Value::as_f64)
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(format!("object {i}: {p} is not a finite number")))
        };
        let s = |p: &str| {
            o.pointer(p)
                .and_then(|x| x.as_str())
                .unwrap_or("")
                .to_string()
        };
        let (cx, cy, cz) = (
            num("/box/center/0")?,
            num("/box/center/1")?,
            num("/box/center/2")?,
        );
        let (w, h, l) = (
            num("/box/size/0")?,
            num("/box/size/1")?,
            num("/box/size/2")?,
        );
        let yaw = num("/box/yaw_rad").unwrap_or(0.0);
        // the length axis turns from +z towards +x by yaw; the width axis is perpendicular
        let (along, across) = ([yaw.sin(), yaw.cos()], [yaw.cos(), -yaw.sin()]);
        let corner = |a: f64, b: f64| {
            [
                cx + a * along[0] * l / 2.0 + b * across[0] * w / 2.0,
                cz + a * along[1] * l / 2.0 + b * across[1] * w / 2.0,
            ]
        };
        out.push(TruthObject {
            id: o["id"].as_i64().unwrap_or(i as i64),
            centre_xz: [cx, cz],
            radius_m: w.max(l) / 2.0,
            footprint: [
                corner(1.0, 1.0),
                corner(1.0, -1.0),
                corner(-1.0, -1.0),
                corner(-1.0, 1.0),
            ],
            // y points down with the ground at y = 0
            heights: (-(cy + h / 2.0), -(cy - h / 2.0)),
            class: s("/class"),
            noun: s("/attributes/noun"),
            colour: s("/attributes/colour"),
            material: s("/attributes/material"),
        });
    }
    Ok(out)
}

/// The ground-truth object an instance centroid (KITTI world frame) belongs to: the nearest
/// centre among the objects whose footprint radius (plus 0.5 m) reaches it.
pub fn match_truth(truth: &[TruthObject], c: [f64; 3]) -> Option<usize> {
    truth
        .iter()
        .enumerate()
        .map(|(i, t)| (i, (t.centre_xz[0] - c[0]).hypot(t.centre_xz[1] - c[2]), t))
        .filter(|(_, d, t)| *d <= t.radius_m + 0.5)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _, _)| i)
}

/// Whether `p` lies inside the convex polygon `poly`.
pub fn inside(p: [f64; 2], poly: &[[f64; 2]; 4]) -> bool {
    // the point is inside when it is on the same side of every edge (or on an edge)
    let (mut left, mut right) = (false, false);
    for k in 0..4 {
        let (a, b) = (poly[k], poly[(k + 1) % 4]);
        let cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        left |= cross > 0.0;
        right |= cross < 0.0;
    }
    !(left && right)
}

/// Distance between two convex footprints (0 when they overlap).
pub fn footprint_gap(a: &[[f64; 2]; 4], b: &[[f64; 2]; 4]) -> f64 {
    if a.iter().any(|p| inside(*p, b)) || b.iter().any(|p| inside(*p, a)) {
        return 0.0;
    }
    let mut best = f64::INFINITY;
    for (p, poly) in a.iter().map(|p| (p, b)).chain(b.iter().map(|p| (p, a))) {
        for k in 0..4 {
            let (_, q) = scene::geom::closest_on_segment(*p, poly[k], poly[(k + 1) % 4]);
            best = best.min((p[0] - q[0]).hypot(p[1] - q[1]));
        }
    }
    // crossing edges without a corner inside: treat as touching
    best
}

/// One road of the truth.
#[derive(Debug, Clone)]
pub struct TrueRoad {
    /// Centre line on the ground plane (x, z).
    pub centerline: Vec<[f64; 2]>,
    /// Half the carriageway width.
    pub half_width_m: f64,
    /// Parking width on the right and left of the `from → to` direction (0 without).
    pub parking_m: [f64; 2],
}

/// Reads the roads of `DIR/ground_truth/roads.json`.
pub fn read_roads(sim_dir: &Path) -> Result<Vec<TrueRoad>> {
    let path = sim_dir.join("ground_truth/roads.json");
    let v = read_json(&path)?;
    let bad = |d: String| Error::File {
        path: path.clone(),
        detail: d,
    };
    let roads = v["roads"]
        .as_array()
        .ok_or_else(|| bad("no \"roads\" array".into()))?;
    let mut out = Vec::new();
    for (i, r) in roads.iter().enumerate() {
        let line: Option<Vec<[f64; 2]>> = r["centerline"]
            .as_array()
            .map(|a| a.iter().filter_map(json_xy).collect());
        let (Some(centerline), Some(w)) = (line, r["width_m"].as_f64()) else {
            return Err(bad(format!("road {i} lacks a centerline or width_m")));
        };
        if centerline.len() < 2 || !(w.is_finite() && w > 0.0) {
            return Err(bad(format!("road {i} has a bad centerline or width_m")));
        }
        let pw = r["parking_width_m"].as_f64().unwrap_or(0.0);
        let side = |k: usize| {
            if r["parking"][k].as_bool().unwrap_or(false) {
                pw
            } else {
                0.0
            }
        };
        out.push(TrueRoad {
            centerline,
            half_width_m: w / 2.0,
            parking_m: [side(0), side(1)],
        });
    }
    Ok(out)
}

/// The lines the simulator's movers keep to (ground plane), from `movers.json`: a car's
/// two lanes (it keeps right both ways), a walker's sidewalk. Empty without the file.
pub fn mover_lines(sim_dir: &Path) -> Result<Option<Vec<Vec<[f64; 2]>>>> {
    let path = sim_dir.join("ground_truth/movers.json");
    if !path.exists() {
        return Ok(None);
    }
    let v = read_json(&path)?;
    let bad = |d: String| Error::File {
        path: path.clone(),
        detail: d,
    };
    let movers = v["movers"]
        .as_array()
        .ok_or_else(|| bad("no \"movers\" array".into()))?;
    let mut out = Vec::new();
    for (i, m) in movers.iter().enumerate() {
        let line: Option<Vec<[f64; 2]>> = m["path"]
            .as_array()
            .and_then(|a| a.iter().map(json_xy).collect());
        let (Some(line), Some(off), Some(side)) =
            (line, m["offset_m"].as_f64(), m["side"].as_f64())
        else {
            return Err(bad(format!(
                "mover {i} lacks a path of [x, z] points, offset_m or side"
            )));
        };
        if line.len() < 2 {
            return Err(bad(format!("mover {i} has a path of fewer than 2 points")));
        }
        let off = off * side;
        let sides: &[f64] = if m["class"] == "car" {
            &[1.0, -1.0]
        } else {
            &[1.0]
        };
        for s in sides {
            out.push(offset_line(&line, off * s));
        }
    }
    Ok((!out.is_empty()).then_some(out))
}

/// `line` moved sideways by `d` metres (to the right of its direction in KITTI's ground
/// plane, `(d.z, -d.x)`, for positive `d`), vertex by vertex.
fn offset_line(line: &[[f64; 2]], d: f64) -> Vec<[f64; 2]> {
    (0..line.len())
        .map(|i| {
            let (a, b) = (line[i.saturating_sub(1)], line[(i + 1).min(line.len() - 1)]);
            let (dx, dz) = (b[0] - a[0], b[1] - a[1]);
            let n = dx.hypot(dz).max(1e-9);
            [line[i][0] + dz / n * d, line[i][1] - dx / n * d]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mover_lines_are_offset_to_the_right() {
        // going +z, right is +x in KITTI's ground plane
        let l = offset_line(&[[0.0, 0.0], [0.0, 10.0]], 2.0);
        assert!((l[0][0] - 2.0).abs() < 1e-12 && (l[1][0] - 2.0).abs() < 1e-12);
        assert!((l[1][1] - 10.0).abs() < 1e-12);
        let l = offset_line(&[[0.0, 0.0], [0.0, 10.0]], -2.0);
        assert!((l[0][0] + 2.0).abs() < 1e-12);
    }
}
