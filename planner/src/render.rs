//! PNG of a road graph, a route and a planned path (road grey, route blue, path red,
//! obstacles black).

use std::path::Path;

use tiny_skia::{Color, Paint, PathBuilder, Pixmap, Stroke, Transform};

use crate::error::{Error, Result};
use crate::graph::RoadGraph;
use crate::motion::{MotionPath, Obstacle};
use crate::route::Route;

/// Draws and writes the PNG, fitting the whole graph.
pub fn write_png(
    path: &Path,
    g: &RoadGraph,
    route: &Route,
    motion: &MotionPath,
    obstacles: &[Obstacle],
) -> Result<()> {
    let pts: Vec<[f64; 2]> = g
        .edges
        .iter()
        .flat_map(|e| e.polyline.iter().copied())
        .chain(route.polyline.iter().copied())
        .collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &pts {
        for i in 0..2 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
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
        let c = [
            [o.min[0], o.min[1]],
            [o.max[0], o.min[1]],
            [o.max[0], o.max[1]],
            [o.min[0], o.max[1]],
            [o.min[0], o.min[1]],
        ];
        line(&c, 2.0, (0, 0, 0, 255));
    }
    pm.save_png(path)
        .map_err(|e| Error::Render(format!("{}: {e}", path.display())))
}
