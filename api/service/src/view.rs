//! What the web viewer draws (`GET /api/view`): every instance's points on the ground plane
//! (subsampled, coloured by SemanticKITTI class in the page, as the paper renders its maps),
//! the lane graph's polylines and the road segments' outlines, in the map's ground frame
//! (metres; KITTI maps: x right, z forward).

use graphstore::{GraphRead, Store};
use serde_json::{Value as Json, json};

/// Points kept per object (per surface tile for road, sidewalk, parking, terrain, other-ground).
pub const POINTS_PER_OBJECT: usize = 64;
/// Points kept per surface tile.
pub const POINTS_PER_SURFACE: usize = 96;

fn r2(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

/// Every `step`-th point so that at most `max` remain (deterministic).
fn subsample<T: Copy>(v: &[T], max: usize) -> Vec<T> {
    if v.len() <= max {
        return v.to_vec();
    }
    let step = v.len().div_ceil(max);
    v.iter().step_by(step).copied().collect()
}

/// The viewer's data: `{ground, bounds: [minx, miny, maxx, maxy], instances: [{id, class,
/// caption, surface, points: [x0, y0, x1, y1, ...]}], lanes: [[x0, y0, ...]], segments: [{id,
/// kind, outline: [x0, y0, ...]}]}` with ground coordinates in metres (2 decimals).
///
/// # Errors
/// The store fails, has no ground frame, or a layer's record lacks a required property
/// ([`scene::export::MapLayers::load`]).
pub fn view(store: &Store) -> Result<Json, String> {
    let r = store.read().map_err(|e| e.to_string())?;
    let layers = scene::export::MapLayers::load(&r).map_err(|e| e.to_string())?;
    let g = layers.ground;
    let surfaces = scene::classes::SURFACE_CLASSES;
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let mut grow = |p: [f64; 2]| {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    };
    let err = |e: graphstore::Error| e.to_string();
    let mut instances = Vec::new();
    for (&id, inst) in &layers.instances {
        let surface = surfaces.contains(&inst.semantic_class.as_str());
        let mut pts: Vec<[f64; 2]> = match r.point_cloud(id, scene::payload::POINTS).map_err(err)? {
            Some(pc) if !pc.xyz.is_empty() => subsample(
                &pc.xyz,
                if surface {
                    POINTS_PER_SURFACE
                } else {
                    POINTS_PER_OBJECT
                },
            )
            .into_iter()
            .map(|p| g.ground([f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]))
            .collect(),
            _ => Vec::new(),
        };
        if pts.is_empty() {
            // an object without points (added by a map edit): its box's corners
            let (a, b) = inst.bbox;
            let (a, b) = (g.ground(a), g.ground(b));
            pts = vec![a, [a[0], b[1]], b, [b[0], a[1]]];
        }
        pts.iter().for_each(|p| grow(*p));
        instances.push(json!({
            "id": id,
            "label": inst.label,
            "semantic_class": inst.semantic_class,
            "caption": inst.caption,
            "surface": surface,
            "points": pts.iter().flat_map(|p| [r2(p[0]), r2(p[1])]).collect::<Vec<f64>>(),
        }));
    }
    let mut lanes = Vec::new();
    for (_, _, _, edge) in &layers.lane_edges {
        let pts: Vec<f64> = edge
            .polyline
            .iter()
            .flat_map(|p| {
                let q = g.ground(*p);
                grow(q);
                [r2(q[0]), r2(q[1])]
            })
            .collect();
        if !pts.is_empty() {
            lanes.push(json!(pts));
        }
    }
    let segments: Vec<Json> = layers
        .segments
        .iter()
        .map(|(id, s)| {
            json!({
                "id": id,
                "kind": s.kind,
                "outline": s.area(g).outline(24).iter().flat_map(|p| [r2(p[0]), r2(p[1])]).collect::<Vec<f64>>(),
            })
        })
        .collect();
    let mut colours = serde_json::Map::new();
    for i in &instances {
        let c = i["semantic_class"].as_str().unwrap_or_default();
        let (r8, g8, b8) = scene::classes::class_colour(c);
        colours.insert(c.to_string(), json!(format!("#{r8:02x}{g8:02x}{b8:02x}")));
    }
    if !lo[0].is_finite() {
        lo = [0.0, 0.0];
        hi = [1.0, 1.0];
    }
    Ok(json!({
        "ground": match g { scene::GroundFrame::KittiCam => "xz", scene::GroundFrame::Enu => "xy" },
        "bounds": [r2(lo[0]), r2(lo[1]), r2(hi[0]), r2(hi[1])],
        "instances": instances,
        "lanes": lanes,
        "segments": segments,
        "colours": colours,
    }))
}
