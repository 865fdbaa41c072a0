//! Bird's-eye PNG and GeoJSON output of the lane graph and segments.
//!
//! PNG colours: trajectory light grey, lane edges blue, segment areas pale yellow (roads) and
//! pale red (junctions); nodes: intersection red, t_intersection orange, l_intersection
//! green, breakpoint black.

use std::path::Path;

use tiny_skia::{Color, Paint, PathBuilder, Pixmap, Stroke, Transform};

use super::lanes::{LaneGraph, LaneNodeKind};
use super::segments::Segments;
use crate::error::{Error, Result};
use scene::area::SegmentArea;

/// Longest image side in pixels.
const MAX_SIDE_PX: f64 = 1600.0;
const MARGIN_PX: f64 = 30.0;

struct View {
    min: [f64; 2],
    scale: f64,
    height: f64,
}

impl View {
    fn fit(points: impl Iterator<Item = [f64; 2]>) -> Option<(View, u32, u32)> {
        let [lo, hi] = scene::geom::bounds(points);
        if !lo[0].is_finite() {
            return None;
        }
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1.0);
        let scale = (MAX_SIDE_PX - 2.0 * MARGIN_PX) / span;
        let w = ((hi[0] - lo[0]) * scale + 2.0 * MARGIN_PX).ceil() as u32;
        let h = ((hi[1] - lo[1]) * scale + 2.0 * MARGIN_PX).ceil() as u32;
        Some((
            View {
                min: lo,
                scale,
                height: f64::from(h),
            },
            w.max(1),
            h.max(1),
        ))
    }

    /// Ground-plane metres to pixels; the second coordinate points up in the image.
    fn px(&self, p: [f64; 2]) -> (f32, f32) {
        (
            (MARGIN_PX + (p[0] - self.min[0]) * self.scale) as f32,
            (self.height - MARGIN_PX - (p[1] - self.min[1]) * self.scale) as f32,
        )
    }
}

fn paint(r: u8, g: u8, b: u8, a: u8) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(Color::from_rgba8(r, g, b, a));
    p.anti_alias = true;
    p
}

fn polyline(pm: &mut Pixmap, v: &View, pts: &[[f64; 2]], width_px: f32, paint: &Paint<'_>) {
    if pts.len() < 2 {
        return;
    }
    let mut pb = PathBuilder::new();
    let (x, y) = v.px(pts[0]);
    pb.move_to(x, y);
    for p in &pts[1..] {
        let (x, y) = v.px(*p);
        pb.line_to(x, y);
    }
    if let Some(path) = pb.finish() {
        let stroke = Stroke {
            width: width_px,
            line_cap: tiny_skia::LineCap::Round,
            line_join: tiny_skia::LineJoin::Round,
            ..Stroke::default()
        };
        pm.stroke_path(&path, paint, &stroke, Transform::identity(), None);
    }
}

fn disc(pm: &mut Pixmap, v: &View, c: [f64; 2], radius_px: f32, paint: &Paint<'_>) {
    let (x, y) = v.px(c);
    if let Some(path) = PathBuilder::from_circle(x, y, radius_px) {
        pm.fill_path(
            &path,
            paint,
            tiny_skia::FillRule::Winding,
            Transform::identity(),
            None,
        );
    }
}

/// Colour of a node kind.
pub fn kind_rgb(kind: LaneNodeKind) -> (u8, u8, u8) {
    match kind {
        LaneNodeKind::Intersection => (220, 30, 30),
        LaneNodeKind::TIntersection => (245, 140, 0),
        LaneNodeKind::LIntersection => (20, 160, 60),
        LaneNodeKind::Breakpoint => (0, 0, 0),
    }
}

/// Draws the trajectory, segment areas, lane edges and nodes, and writes a PNG.
pub fn write_png(
    path: &Path,
    traj: &[[f64; 2]],
    lanes: &LaneGraph,
    segments: Option<&Segments>,
) -> Result<()> {
    // the segment areas are drawn whole: their extents count for the fit
    let mut extents: Vec<[f64; 2]> = Vec::new();
    for s in segments.map(|s| s.segments.as_slice()).unwrap_or_default() {
        let (pts, r) = match &s.area {
            SegmentArea::Disc { centre, radius_m } => (vec![*centre], *radius_m),
            SegmentArea::Corridor {
                centreline,
                half_width_m,
            } => (centreline.clone(), *half_width_m),
        };
        for p in pts {
            extents.extend([[p[0] - r, p[1] - r], [p[0] + r, p[1] + r]]);
        }
    }
    let all = traj
        .iter()
        .copied()
        .chain(lanes.nodes.iter().map(|n| n.xy))
        .chain(extents);
    let (v, w, h) = View::fit(all).ok_or_else(|| Error::Invalid("nothing to draw".into()))?;
    let mut pm =
        Pixmap::new(w, h).ok_or_else(|| Error::Render(format!("cannot allocate {w}x{h} image")))?;
    pm.fill(Color::WHITE);
    if let Some(segs) = segments {
        for s in &segs.segments {
            match &s.area {
                SegmentArea::Disc { centre, radius_m } => {
                    disc(
                        &mut pm,
                        &v,
                        *centre,
                        (*radius_m * v.scale) as f32,
                        &paint(255, 120, 120, 90),
                    );
                }
                SegmentArea::Corridor {
                    centreline,
                    half_width_m,
                } => {
                    polyline(
                        &mut pm,
                        &v,
                        centreline,
                        (2.0 * half_width_m * v.scale) as f32,
                        &paint(250, 210, 80, 90),
                    );
                }
            }
        }
    }
    polyline(&mut pm, &v, traj, 1.0, &paint(150, 150, 150, 255));
    for e in &lanes.edges {
        polyline(&mut pm, &v, &e.polyline, 2.5, &paint(30, 80, 220, 230));
    }
    for n in &lanes.nodes {
        let (r, g, b) = kind_rgb(n.kind);
        disc(&mut pm, &v, n.xy, 6.0, &paint(r, g, b, 255));
    }
    pm.save_png(path).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        error: std::io::Error::other(e.to_string()),
    })
}

/// A ground-plane point rounded to millimetres (no `-1.2e-16` noise, no `-0`).
fn mm(p: [f64; 2]) -> [f64; 2] {
    [
        (p[0] * 1000.0).round() / 1000.0 + 0.0,
        (p[1] * 1000.0).round() / 1000.0 + 0.0,
    ]
}

/// The lane graph (and segments, if given) as a GeoJSON FeatureCollection in ground-plane
/// metres (not longitude/latitude), rounded to millimetres.
pub fn geojson(lanes: &LaneGraph, segments: Option<&Segments>) -> serde_json::Value {
    use serde_json::json;
    let line = |ps: &[[f64; 2]]| ps.iter().map(|p| mm(*p)).collect::<Vec<_>>();
    let mut features = Vec::new();
    for n in &lanes.nodes {
        features.push(json!({
            "type": "Feature",
            "geometry": {"type": "Point", "coordinates": mm(n.xy)},
            "properties": {"layer": "lane_node", "id": n.id, "kind": n.kind.as_str(), "ways": n.ways},
        }));
    }
    for (i, e) in lanes.edges.iter().enumerate() {
        features.push(json!({
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": line(&e.polyline)},
            "properties": {"layer": "lane_edge", "id": i, "from": e.from, "to": e.to, "length_m": e.length_m, "frames": e.frames.len()},
        }));
    }
    if let Some(segs) = segments {
        for s in &segs.segments {
            let ring = line(&s.area.outline(24));
            features.push(json!({
                "type": "Feature",
                "geometry": {"type": "Polygon", "coordinates": [ring]},
                "properties": {"layer": "segment", "id": s.id, "kind": s.kind.as_str()},
            }));
        }
    }
    json!({"type": "FeatureCollection", "features": features})
}

/// `{"nodes": [{"id", "kind", "xy"}], "edges": [{"from", "to", "length_m"}]}`.
pub fn lanes_json(lanes: &LaneGraph) -> serde_json::Value {
    use serde_json::json;
    json!({
        "nodes": lanes.nodes.iter().map(|n| json!({"id": n.id, "kind": n.kind.as_str(), "xy": n.xy})).collect::<Vec<_>>(),
        "edges": lanes.edges.iter().map(|e| json!({"from": e.from, "to": e.to, "length_m": e.length_m})).collect::<Vec<_>>(),
        "gaps": lanes.gaps.iter().map(|g| json!({"after_pose": g.after_pose, "distance_m": g.distance_m})).collect::<Vec<_>>(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geojson_coordinates_are_millimetres() {
        let near =
            |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12;
        assert!(near(
            mm([-1.224_646_799_147_353_2e-16, 3.649e-48]),
            [0.0, 0.0]
        ));
        // no "-0" in the output
        assert!(mm([-1e-9, 0.0])[0].is_sign_positive());
        assert!(near(mm([12.345_678, -0.000_4]), [12.346, 0.0]));
    }
}
