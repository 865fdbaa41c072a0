//! PNG of a road graph, a route and a planned path (road grey, route blue, path red,
//! obstacles black).

use std::path::Path;

use tiny_skia::{Color, Paint, PathBuilder, Pixmap, Stroke, Transform};

use crate::error::{Error, Result};
use crate::graph::RoadGraph;
use crate::motion::{MotionPath, Obstacle};
use crate::route::Route;
use scene::records::InstanceRecord;

/// An instance to draw: its ground footprint, its points on the ground (drawn when present, as
/// the web viewer and the paper render maps; else the box is filled), its class.
#[derive(Debug, Clone, PartialEq)]
pub struct Footprint {
    /// Min corner.
    pub min: [f64; 2],
    /// Max corner.
    pub max: [f64; 2],
    /// Class name (colours follow SemanticKITTI's colour map).
    pub class: String,
    /// Ground positions of (a subsample of) its points, metres.
    pub points: Vec<[f64; 2]>,
    /// Whether it is a ground surface (road, sidewalk, ...), drawn faintly.
    pub surface: bool,
}

/// Points drawn per instance (surface tiles get twice as many).
pub const POINTS_PER_INSTANCE: usize = 64;

/// Every instance of the store that is not a ground surface, as footprints, by id.
pub fn instance_footprints(
    r: &impl graphstore::GraphRead,
    ground: scene::GroundFrame,
) -> Result<Vec<Footprint>> {
    let mut out = Vec::new();
    for id in r.nodes_with_label(scene::label::INSTANCE)? {
        let Some(inst) = InstanceRecord::read(r, id)? else {
            continue;
        };
        let class = inst.semantic_class;
        let surface = crate::motion::GROUND_CLASSES.contains(&class.as_str());
        let (lo, hi) = inst.bbox;
        let (a, b) = (ground.ground(lo), ground.ground(hi));
        let max_points = if surface {
            2 * POINTS_PER_INSTANCE
        } else {
            POINTS_PER_INSTANCE
        };
        let points = match r.point_cloud(id, scene::payload::POINTS)? {
            Some(pc) if !pc.xyz.is_empty() => {
                let step = pc.xyz.len().div_ceil(max_points);
                pc.xyz
                    .iter()
                    .step_by(step)
                    .map(|p| ground.ground([f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]))
                    .collect()
            }
            _ => Vec::new(),
        };
        out.push(Footprint {
            min: [a[0].min(b[0]), a[1].min(b[1])],
            max: [a[0].max(b[0]), a[1].max(b[1])],
            class,
            points,
            surface,
        });
    }
    Ok(out)
}

/// Draws and writes the PNG, fitting the whole graph.
pub fn write_png(
    path: &Path,
    g: &RoadGraph,
    route: &Route,
    motion: &MotionPath,
    obstacles: &[Obstacle],
) -> Result<()> {
    write_map_png(path, g, route, motion, obstacles, &[], &[])
}

/// A round marker: ground position and RGB colour.
pub type Marker = ([f64; 2], (u8, u8, u8));

/// [`write_png`] with the map's instances drawn underneath, their points in their class colour, and
/// round markers (ground position, RGB) on top: `plan` and `navigate` mark the start green and
/// the goal red.
pub fn write_map_png(
    path: &Path,
    g: &RoadGraph,
    route: &Route,
    motion: &MotionPath,
    obstacles: &[Obstacle],
    instances: &[Footprint],
    markers: &[Marker],
) -> Result<()> {
    let pts: Vec<[f64; 2]> = g
        .edges
        .iter()
        .flat_map(|e| e.polyline.iter().copied())
        .chain(route.polyline.iter().copied())
        // surface tiles far off the road (terrain seen at range) would shrink the map
        .chain(
            instances
                .iter()
                .filter(|f| !f.surface)
                .flat_map(|f| [f.min, f.max]),
        )
        .collect();
    let [lo, hi] = scene::geom::bounds(&pts);
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1.0);
    let scale = 1540.0 / span;
    let (w, h) = (
        ((hi[0] - lo[0]) * scale + 60.0) as u32,
        ((hi[1] - lo[1]) * scale + 60.0) as u32,
    );
    let mut pm = Pixmap::new(w.max(1), h.max(1))
        .ok_or_else(|| Error::Render(format!("cannot allocate {w}x{h}")))?;
    pm.fill(Color::WHITE);
    let px = |p: [f64; 2]| {
        (
            (30.0 + (p[0] - lo[0]) * scale) as f32,
            (f64::from(h) - 30.0 - (p[1] - lo[1]) * scale) as f32,
        )
    };
    // surfaces first and faint, then objects: points where there are, else the filled box
    for pass in [true, false] {
        for f in instances.iter().filter(|f| f.surface == pass) {
            let (r, gr, b) = scene::classes::class_colour(&f.class);
            let mut paint = Paint::default();
            paint.set_color(Color::from_rgba8(r, gr, b, if pass { 70 } else { 220 }));
            if f.points.is_empty() {
                let (x0, y0) = px([f.min[0], f.max[1]]);
                let (x1, y1) = px([f.max[0], f.min[1]]);
                if let Some(rect) =
                    tiny_skia::Rect::from_ltrb(x0, y0, x1.max(x0 + 1.0), y1.max(y0 + 1.0))
                {
                    pm.fill_rect(rect, &paint, Transform::identity(), None);
                }
                continue;
            }
            for p in &f.points {
                let (x, y) = px(*p);
                if let Some(rect) = tiny_skia::Rect::from_xywh(x - 1.0, y - 1.0, 2.0, 2.0) {
                    pm.fill_rect(rect, &paint, Transform::identity(), None);
                }
            }
        }
    }
    let mut line = |pts: &[[f64; 2]], width: f32, rgba: (u8, u8, u8, u8)| {
        if pts.len() < 2 {
            return;
        }
        let mut pb = PathBuilder::new();
        let (x, y) = px(pts[0]);
        pb.move_to(x, y);
        for p in &pts[1..] {
            let (x, y) = px(*p);
            pb.line_to(x, y);
        }
        if let Some(path) = pb.finish() {
            let mut paint = Paint::default();
            paint.set_color(Color::from_rgba8(rgba.0, rgba.1, rgba.2, rgba.3));
            paint.anti_alias = true;
            pm.stroke_path(
                &path,
                &paint,
                &Stroke {
                    width,
                    ..Stroke::default()
                },
                Transform::identity(),
                None,
            );
        }
    };
    for e in &g.edges {
        line(&e.polyline, 2.0, (170, 170, 170, 255));
    }
    line(&route.polyline, 5.0, (40, 90, 230, 160));
    let driven: Vec<[f64; 2]> = motion.poses.iter().map(|p| [p[0], p[1]]).collect();
    line(&driven, 1.5, (220, 30, 30, 255));
    for o in obstacles {
        let k = o.footprint.corners();
        let c = [k[0], k[1], k[2], k[3], k[0]];
        line(&c, 2.0, (0, 0, 0, 255));
    }
    for (p, (r, gr, b)) in markers {
        let (x, y) = px(*p);
        if let Some(circle) = PathBuilder::from_circle(x, y, 9.0) {
            let mut paint = Paint::default();
            paint.set_color(Color::from_rgba8(*r, *gr, *b, 230));
            paint.anti_alias = true;
            pm.fill_path(
                &circle,
                &paint,
                tiny_skia::FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
    }
    pm.save_png(path)
        .map_err(|e| Error::Render(format!("{}: {e}", path.display())))
}
