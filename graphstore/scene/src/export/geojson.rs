//! GeoJSON (RFC 7946 structure) of the map's ground plane: lane edges as `LineString`s, lane
//! nodes as `Point`s, each segment's area (a junction's disc as a 64-gon `Polygon` around
//! it, a road's corridor as the `MultiPolygon` buffer of its centre line, round joins and
//! ends), each measured drivable area as a `MultiPolygon` (holes clockwise inside
//! their outer ring), and each instance's footprint (its oriented box, or its axis-aligned
//! box when it has none) as a `Polygon`, or a `LineString` or `Point` where the box has no
//! width.
//!
//! Coordinates are **ground-plane metres of the map's world frame** (KITTI's x and z, or ENU's
//! x and y), not longitude and latitude: the collection's foreign member `opengraph_frame`
//! says which. Every feature has `layer` (`lane`, `lane_node`, `segment`, `drivable`,
//! `instance`) and `id` (the node or relationship id `find`, `query` and `plan` use).

use serde_json::{Value as Json, json};

use super::MapLayers;
use crate::area::SegmentArea;
use crate::records::SegmentShape;

/// A footprint's half extent under this many metres is no extent: the footprint is a line
/// (or a point).
const FLAT_M: f64 = 1e-6;

fn mid(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0]
}

/// Vertices of a junction disc's outline.
pub const DISC_VERTICES: usize = 64;

/// A ring closed as GeoJSON wants it (first point repeated last), counter-clockwise.
fn closed_ccw(mut ring: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    if ring.len() > 1 && ring.first() == ring.last() {
        ring.pop();
    }
    let twice_area: f64 = (0..ring.len())
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    if twice_area < 0.0 {
        ring.reverse();
    }
    if let Some(f) = ring.first().copied() {
        ring.push(f);
    }
    ring
}

/// The corridor around a centre line: every point within `half_width_m` of it (as
/// [`SegmentArea::distance`] measures it), as polygons with round joins and caps (geo's
/// buffer).
pub fn corridor_polygons(centreline: &[[f64; 2]], half_width_m: f64) -> geo::MultiPolygon<f64> {
    use geo::Buffer;
    let line: geo::LineString<f64> = centreline.iter().map(|p| (p[0], p[1])).collect();
    if line.0.len() < 2 {
        return geo::MultiPolygon(Vec::new());
    }
    line.buffer(half_width_m)
}

fn ring_json(ring: &[[f64; 2]]) -> Json {
    Json::Array(ring.iter().map(|p| json!([p[0], p[1]])).collect())
}

fn polygon_json(p: &geo::Polygon<f64>) -> Json {
    let ring =
        |r: &geo::LineString<f64>| -> Vec<[f64; 2]> { r.0.iter().map(|c| [c.x, c.y]).collect() };
    let mut rings = vec![ring_json(&closed_ccw(ring(p.exterior())))];
    for h in p.interiors() {
        let mut r = closed_ccw(ring(h));
        // holes run clockwise
        r.reverse();
        rings.push(ring_json(&r));
    }
    Json::Array(rings)
}

/// A drivable area's even-odd rings as valid polygons: the rings combined by symmetric
/// difference (geo's boolean operations), so a ring that touches itself where two parts of
/// the area meet at a point becomes polygons that meet there, and a hole lies inside its
/// outer ring.
pub fn drivable_polygons(rings: &[Vec<[f64; 2]>]) -> geo::MultiPolygon<f64> {
    use geo::BooleanOps;
    let mut acc = geo::MultiPolygon::<f64>(Vec::new());
    for r in rings.iter().filter(|r| r.len() >= 3) {
        let ring: geo::LineString<f64> = r.iter().map(|p| (p[0], p[1])).collect();
        acc = acc.xor(&geo::Polygon::new(ring, Vec::new()));
    }
    acc
}

/// The whole map's ground plane as one GeoJSON `FeatureCollection`.
pub fn feature_collection(m: &MapLayers) -> Json {
    let g = m.ground;
    let mut features = Vec::new();
    for (rel, a, b, e) in &m.lane_edges {
        let line: Vec<[f64; 2]> = e.polyline.iter().map(|p| g.ground(*p)).collect();
        features.push(json!({
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": ring_json(&line)},
            "properties": {"layer": "lane", "id": rel, "from": a, "to": b,
                           "length_m": e.length_m, "directed": e.directed}
        }));
    }
    for (id, n) in &m.lane_nodes {
        let p = g.ground(n.position);
        features.push(json!({
            "type": "Feature",
            "geometry": {"type": "Point", "coordinates": [p[0], p[1]]},
            "properties": {"layer": "lane_node", "id": id, "lane_id": n.lane_id, "kind": n.kind}
        }));
    }
    for (id, s) in &m.segments {
        let geometry = match s.area(g) {
            // the polygon's edges outside the circle, so it holds the whole disc
            SegmentArea::Disc { centre, radius_m } => {
                let ring = SegmentArea::Disc {
                    centre,
                    radius_m: radius_m / (std::f64::consts::PI / DISC_VERTICES as f64).cos(),
                }
                .outline(DISC_VERTICES);
                json!({"type": "Polygon", "coordinates": [ring_json(&closed_ccw(ring))]})
            }
            SegmentArea::Corridor {
                centreline,
                half_width_m,
            } => {
                let polys = corridor_polygons(&centreline, half_width_m);
                json!({"type": "MultiPolygon",
                       "coordinates": polys.0.iter().map(polygon_json).collect::<Vec<_>>()})
            }
        };
        let shape = match &s.shape {
            Some(SegmentShape::Disc { radius_m, .. }) => json!({"disc_radius_m": radius_m}),
            Some(SegmentShape::Corridor { half_width_m, .. }) => {
                json!({"corridor_half_width_m": half_width_m})
            }
            None => json!({"disc_radius_m": crate::records::DEFAULT_SEGMENT_RADIUS_M}),
        };
        let mut props = json!({"layer": "segment", "id": id, "segment_id": s.segment_id,
                               "kind": s.kind});
        if let (Some(o), Some(x)) = (props.as_object_mut(), shape.as_object()) {
            o.extend(x.clone());
        }
        features.push(json!({"type": "Feature", "geometry": geometry, "properties": props}));
        if let Some(d) = s.drivable(g) {
            let polys: Vec<Json> = drivable_polygons(&d.rings)
                .0
                .iter()
                .map(polygon_json)
                .collect();
            features.push(json!({
                "type": "Feature",
                "geometry": {"type": "MultiPolygon", "coordinates": polys},
                "properties": {"layer": "drivable", "id": id, "segment_id": s.segment_id,
                               "area_m2": s.drivable_area_m2}
            }));
        }
    }
    for (id, i) in &m.instances {
        let footprint = i
            .obb
            .unwrap_or_else(|| crate::OrientedBox::from_aabb(g, i.bbox.0, i.bbox.1));
        // a footprint of no width (points on a line, or one point) is that line or point
        let [hl, hw] = footprint.half_extents;
        let geometry = if hw > FLAT_M {
            json!({"type": "Polygon",
                   "coordinates": [ring_json(&closed_ccw(footprint.corners().to_vec()))]})
        } else if hl > FLAT_M {
            let c = footprint.corners();
            let (a, b) = (mid(c[0], c[3]), mid(c[1], c[2]));
            json!({"type": "LineString", "coordinates": ring_json(&[a, b])})
        } else {
            json!({"type": "Point", "coordinates": footprint.center})
        };
        features.push(json!({
            "type": "Feature",
            "geometry": geometry,
            "properties": {"layer": "instance", "id": id, "instance_id": i.instance_id,
                           "label": i.label, "semantic_class": i.semantic_class,
                           "caption": i.caption,
                           "height_m": footprint.height_m}
        }));
    }
    json!({
        "type": "FeatureCollection",
        "opengraph_frame": format!(
            "ground-plane coordinates [{}] of the {}; not longitude and latitude",
            match g {
                crate::GroundFrame::KittiCam => "x, z",
                crate::GroundFrame::Enu => "x, y",
            },
            m.frame_words()
        ),
        "features": features
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_corridor_polygon_holds_the_corridor() {
        use geo::{Area, Contains};
        let line = [[0.0, 0.0], [10.0, 0.0], [20.0, 0.0], [20.0, 15.0]];
        let polys = corridor_polygons(&line, 2.0);
        // the two rectangles less their overlap inside the bend (2 x 2), a quarter circle
        // outside it and the two half circles at the ends
        let exact = 35.0 * 4.0 - 4.0 + std::f64::consts::PI * 4.0 * 1.25;
        let area = polys.unsigned_area();
        assert!((area - exact).abs() < 0.01 * exact, "{area} vs {exact}");
        let area_of = SegmentArea::Corridor {
            centreline: line.to_vec(),
            half_width_m: 2.0,
        };
        for p in [
            [0.0, 1.9],
            [-1.8, 0.0],
            [21.3, 1.3],
            [10.0, -1.9],
            [21.9, 8.0],
        ] {
            assert!(area_of.distance(p) <= 1e-9, "{p:?}");
            assert!(polys.contains(&geo::Point::new(p[0], p[1])), "{p:?}");
        }
        assert!(!polys.contains(&geo::Point::new(10.0, 2.1)));
        let j = polygon_json(&polys.0[0]);
        assert!(j[0].as_array().unwrap().len() > 4);
    }

    #[test]
    fn a_hole_stays_inside_its_outer_ring_and_a_pinch_is_split() {
        use geo::{Area, Validation};
        let outer = vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let hole = vec![[4.0, 4.0], [4.0, 6.0], [6.0, 6.0], [6.0, 4.0]];
        let other = vec![[20.0, 0.0], [22.0, 0.0], [22.0, 2.0]];
        let p = drivable_polygons(&[outer, hole, other]);
        assert_eq!(p.0.len(), 2);
        assert!((p.unsigned_area() - (100.0 - 4.0 + 2.0)).abs() < 1e-9);
        assert!(p.0.iter().any(|q| q.interiors().len() == 1));
        // one ring through the same point twice (two squares meeting at a corner)
        let pinched = vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [2.0, 1.0],
            [2.0, 2.0],
            [1.0, 2.0],
            [1.0, 1.0],
            [0.0, 1.0],
        ];
        let p = drivable_polygons(&[pinched]);
        assert!(p.is_valid(), "{p:?}");
        assert!((p.unsigned_area() - 2.0).abs() < 1e-9);
    }
}
