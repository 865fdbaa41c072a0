//! One typed record per layer of the map (environment, segment, lane node and edge, instance,
//! relation, edit), each with the store properties it writes ([`EnvironmentRecord::props`]
//! and the like, in one fixed order) and the reading back ([`EnvironmentRecord::read`]).
//! Positions are world metres in the map's frame; [`GroundFrame`] turns them into ground
//! coordinates.

use graphstore::{GraphRead, Value, WriteTxn};

use crate::area::{Drivable, SegmentArea};
use crate::error::{Error, Result};
use crate::names::{key, label, rel};
use crate::{GroundFrame, OrientedBox};

/// The world axes of the map's ground plane ([`GroundFrame::ground_axes`]), as Cypher's ground
/// procedures take them (`QueryOptions::ground_axes`); None when the store cannot be read or
/// the map has no ground frame yet.
pub fn ground_axes(store: &graphstore::Store) -> Option<[usize; 2]> {
    let r = store.read().ok()?;
    ground_frame(&r).ok().map(GroundFrame::ground_axes)
}

/// The map's ground frame, from its `Environment.ground_frame`.
///
/// # Errors
/// [`Error::NoGroundFrame`] when the store has no Environment node, or its ground frame is
/// missing or unknown (none is guessed); [`Error::Store`] when the store fails.
pub fn ground_frame(r: &impl GraphRead) -> Result<GroundFrame> {
    let env = r.nodes_with_label(label::ENVIRONMENT)?;
    let Some(id) = env.first() else {
        return Err(Error::NoGroundFrame(
            "the map has no Environment node yet".into(),
        ));
    };
    let name = r
        .node_prop(*id, key::GROUND_FRAME)?
        .and_then(|v| v.as_str().map(str::to_string));
    match name.as_deref() {
        Some(n) => GroundFrame::from_name(n).ok_or_else(|| {
            Error::NoGroundFrame(format!(
                "Environment node {id} has ground_frame {n:?}; known: \"kitti_cam\" (x, z) and \"enu\" (x, y)"
            ))
        }),
        None => Err(Error::NoGroundFrame(format!(
            "Environment node {id} has no ground_frame"
        ))),
    }
}

/// The oriented box of an `Instance.obb` property (a list of [`crate::OBB_VALUES`] numbers);
/// `None` for anything else.
pub fn obb_of(v: &Value) -> Option<OrientedBox> {
    let Value::List(v) = v else { return None };
    let f: Option<Vec<f64>> = v.iter().map(Value::as_f64).collect();
    f.and_then(|f| OrientedBox::from_values(&f))
}

/// The `Instance.obb` property of a box ([`OrientedBox::to_values`]).
pub fn obb_value(b: &OrientedBox) -> Value {
    Value::List(b.to_values().into_iter().map(Value::Float).collect())
}

/// A node's properties by name (each name looked up as a token when asked, so reading a
/// record makes no string per property).
struct Props<'r, R> {
    node: graphstore::Node,
    r: &'r R,
}

impl<'r, R: GraphRead> Props<'r, R> {
    /// Node `id` when it exists and carries `label`.
    fn of(r: &'r R, id: u64, label: &str) -> Result<Option<Props<'r, R>>> {
        Ok(r.node(id)?.and_then(|node| Self::labelled(r, node, label)))
    }

    /// [`Props::of`] with only the properties named `keys` decoded
    /// ([`GraphRead::node_keys`]); the others read as missing.
    fn of_keys(r: &'r R, id: u64, label: &str, keys: &[&str]) -> Result<Option<Props<'r, R>>> {
        let keys: Vec<graphstore::PropKey> = keys.iter().filter_map(|k| r.prop_key(k)).collect();
        Ok(r.node_keys(id, &keys)?
            .and_then(|node| Self::labelled(r, node, label)))
    }

    /// `node`'s properties when it carries `label`.
    fn labelled(r: &'r R, node: graphstore::Node, label: &str) -> Option<Props<'r, R>> {
        r.label(label)
            .is_some_and(|l| node.labels.contains(&l))
            .then_some(Props { node, r })
    }

    fn get(&self, name: &str) -> Option<&Value> {
        self.node.get(self.r.prop_key(name)?)
    }

    fn str(&self, name: &str) -> Option<String> {
        self.get(name).and_then(Value::as_str).map(str::to_string)
    }

    fn float(&self, name: &str) -> Option<f64> {
        match self.get(name) {
            Some(Value::Float(x)) => Some(*x),
            _ => None,
        }
    }

    fn int(&self, name: &str) -> Option<i64> {
        match self.get(name) {
            Some(Value::Int(x)) => Some(*x),
            _ => None,
        }
    }

    fn need<T>(&self, what: &str, v: Option<T>) -> Result<T> {
        v.ok_or_else(|| {
            Error::Invalid(format!(
                "node {} has no valid {what} property",
                self.node.id
            ))
        })
    }
}

fn points(v: &[[f64; 3]]) -> Value {
    Value::List(v.iter().map(|p| Value::Point3D(*p)).collect())
}

fn points_of(v: Option<&Value>) -> Vec<[f64; 3]> {
    match v {
        Some(Value::List(l)) => l.iter().filter_map(Value::as_point3).collect(),
        _ => Vec::new(),
    }
}

fn rel_props(r: &impl GraphRead, id: u64) -> Result<Vec<(String, Value)>> {
    let Some(rel) = r.rel(id)? else {
        return Err(Error::Invalid(format!("no relationship {id}")));
    };
    Ok(rel
        .props
        .iter()
        .filter_map(|(k, v)| Some((r.name_of(k.0)?, v.clone())))
        .collect())
}

fn find<'a>(props: &'a [(String, Value)], name: &str) -> Option<&'a Value> {
    props.iter().find(|(n, _)| n == name).map(|(_, v)| v)
}

/// The root of the hierarchy (`Environment`).
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentRecord {
    /// The environment's name (unique).
    pub name: String,
    /// Where the hierarchy came from (`trajectory`).
    pub source: Option<String>,
    /// Which world axes span the ground.
    pub ground_frame: Option<GroundFrame>,
}

impl EnvironmentRecord {
    /// The node's properties: name, source, ground_frame.
    pub fn props(&self) -> Vec<(&'static str, Value)> {
        let mut p = vec![(key::NAME, Value::from(self.name.as_str()))];
        if let Some(s) = &self.source {
            p.push((key::SOURCE, s.as_str().into()));
        }
        if let Some(g) = self.ground_frame {
            p.push((key::GROUND_FRAME, g.name().into()));
        }
        p
    }

    /// Creates the node; returns its id.
    ///
    /// # Errors
    /// The store refuses the write (schema, uniqueness).
    pub fn create(&self, tx: &mut WriteTxn<'_>) -> graphstore::Result<u64> {
        tx.create_node_named(&[label::ENVIRONMENT], &self.props())
    }

    /// Environment node `id`; `None` when there is no such node.
    ///
    /// # Errors
    /// The store fails, or the node has no name.
    pub fn read(r: &impl GraphRead, id: u64) -> Result<Option<EnvironmentRecord>> {
        let Some(p) = Props::of(r, id, label::ENVIRONMENT)? else {
            return Ok(None);
        };
        Ok(Some(EnvironmentRecord {
            name: p.need(key::NAME, p.str(key::NAME))?,
            source: p.str(key::SOURCE),
            ground_frame: p
                .str(key::GROUND_FRAME)
                .and_then(|n| GroundFrame::from_name(&n)),
        }))
    }
}

/// The shape a segment covers, as stored: a junction's disc (with its outline) or a road's
/// corridor (its centre line), in world metres.
#[derive(Debug, Clone, PartialEq)]
pub enum SegmentShape {
    /// A junction.
    Disc {
        /// The disc's radius.
        radius_m: f64,
        /// Its outline, world points (`Segment.area`).
        outline: Vec<[f64; 3]>,
    },
    /// A road.
    Corridor {
        /// Half the corridor's width.
        half_width_m: f64,
        /// The centre line, world points (`Segment.centerline`).
        centerline: Vec<[f64; 3]>,
    },
}

/// Radius of a segment whose shape is unknown, metres.
pub const DEFAULT_SEGMENT_RADIUS_M: f64 = 12.0;

/// A road segment (`Segment`).
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentRecord {
    /// The segment's number (unique).
    pub segment_id: i64,
    /// intersection, t_intersection, l_intersection or straight_roadway.
    pub kind: String,
    /// Its centre, world metres.
    pub centroid: [f64; 3],
    /// Its disc or corridor, when known.
    pub shape: Option<SegmentShape>,
    /// Its bounding box (min, max), world metres.
    pub bbox: Option<([f64; 3], [f64; 3])>,
    /// Its drivable area measured from the map: rings of world points, even-odd (empty:
    /// none).
    pub polygon: Vec<Vec<[f64; 3]>>,
    /// The drivable area's size, m².
    pub drivable_area_m2: Option<f64>,
}

impl SegmentRecord {
    /// The node's properties: segment_id, kind, centroid, the shape's (radius_m and area, or
    /// half_width_m and centerline), bbox, polygon and drivable_area_m2.
    pub fn props(&self) -> Vec<(&'static str, Value)> {
        let mut p = vec![
            (key::SEGMENT_ID, Value::Int(self.segment_id)),
            (key::KIND, self.kind.as_str().into()),
            (key::CENTROID, Value::Point3D(self.centroid)),
        ];
        match &self.shape {
            Some(SegmentShape::Disc { radius_m, outline }) => {
                p.push((key::RADIUS_M, Value::Float(*radius_m)));
                p.push((key::AREA, points(outline)));
            }
            Some(SegmentShape::Corridor {
                half_width_m,
                centerline,
            }) => {
                p.push((key::HALF_WIDTH_M, Value::Float(*half_width_m)));
                p.push((key::CENTERLINE, points(centerline)));
            }
            None => {}
        }
        if let Some((lo, hi)) = self.bbox {
            p.push((key::BBOX, Value::box3d(lo, hi)));
        }
        if !self.polygon.is_empty() {
            p.push((
                key::POLYGON,
                Value::List(self.polygon.iter().map(|r| points(r)).collect()),
            ));
        }
        if let Some(a) = self.drivable_area_m2 {
            p.push((key::DRIVABLE_AREA_M2, Value::Float(a)));
        }
        p
    }

    /// Creates the node; returns its id.
    ///
    /// # Errors
    /// The store refuses the write.
    pub fn create(&self, tx: &mut WriteTxn<'_>) -> graphstore::Result<u64> {
        tx.create_node_named(&[label::SEGMENT], &self.props())
    }

    /// Segment node `id`; `None` when there is no such node or it has no centroid.
    ///
    /// # Errors
    /// The store fails.
    pub fn read(r: &impl GraphRead, id: u64) -> Result<Option<SegmentRecord>> {
        let Some(p) = Props::of(r, id, label::SEGMENT)? else {
            return Ok(None);
        };
        let Some(centroid) = p.get(key::CENTROID).and_then(Value::as_point3) else {
            return Ok(None);
        };
        let shape = match (
            p.float(key::RADIUS_M),
            p.get(key::CENTERLINE),
            p.float(key::HALF_WIDTH_M),
        ) {
            (Some(radius_m), _, _) => Some(SegmentShape::Disc {
                radius_m,
                outline: points_of(p.get(key::AREA)),
            }),
            (_, Some(Value::List(_)), Some(half_width_m)) => Some(SegmentShape::Corridor {
                half_width_m,
                centerline: points_of(p.get(key::CENTERLINE)),
            }),
            _ => None,
        };
        // a polygon that is not a list of lists of points is no polygon
        let polygon = match p.get(key::POLYGON) {
            Some(Value::List(rings)) => rings
                .iter()
                .map(|r| match r {
                    Value::List(pts) => pts.iter().map(Value::as_point3).collect(),
                    _ => None,
                })
                .collect::<Option<Vec<Vec<[f64; 3]>>>>()
                .unwrap_or_default(),
            _ => Vec::new(),
        };
        Ok(Some(SegmentRecord {
            segment_id: p.int(key::SEGMENT_ID).unwrap_or_default(),
            kind: p.str(key::KIND).unwrap_or_default(),
            centroid,
            shape,
            bbox: p.get(key::BBOX).and_then(Value::as_box3d),
            polygon,
            drivable_area_m2: p.float(key::DRIVABLE_AREA_M2),
        }))
    }

    /// The area on the ground plane: the disc around the centroid, the corridor along the
    /// centre line, or a disc of [`DEFAULT_SEGMENT_RADIUS_M`] when the shape is unknown.
    pub fn area(&self, g: GroundFrame) -> SegmentArea {
        let centre = g.ground(self.centroid);
        match &self.shape {
            Some(SegmentShape::Disc { radius_m, .. }) => SegmentArea::Disc {
                centre,
                radius_m: *radius_m,
            },
            Some(SegmentShape::Corridor {
                half_width_m,
                centerline,
            }) => SegmentArea::Corridor {
                centreline: centerline.iter().map(|p| g.ground(*p)).collect(),
                half_width_m: *half_width_m,
            },
            None => SegmentArea::Disc {
                centre,
                radius_m: DEFAULT_SEGMENT_RADIUS_M,
            },
        }
    }

    /// The drivable area on the ground plane; `None` without a polygon.
    pub fn drivable(&self, g: GroundFrame) -> Option<Drivable> {
        let d = Drivable {
            rings: self
                .polygon
                .iter()
                .map(|r| r.iter().map(|p| g.ground(*p)).collect())
                .collect(),
        };
        (!d.is_empty()).then_some(d)
    }
}

/// A lane-graph vertex (`LaneNode`).
#[derive(Debug, Clone, PartialEq)]
pub struct LaneNodeRecord {
    /// The vertex's number (unique).
    pub lane_id: i64,
    /// intersection, t_intersection, l_intersection or breakpoint.
    pub kind: String,
    /// Its position, world metres.
    pub position: [f64; 3],
}

impl LaneNodeRecord {
    /// The node's properties: lane_id, kind, position.
    pub fn props(&self) -> Vec<(&'static str, Value)> {
        vec![
            (key::LANE_ID, Value::Int(self.lane_id)),
            (key::KIND, self.kind.as_str().into()),
            (key::POSITION, Value::Point3D(self.position)),
        ]
    }

    /// Creates the node; returns its id.
    ///
    /// # Errors
    /// The store refuses the write.
    pub fn create(&self, tx: &mut WriteTxn<'_>) -> graphstore::Result<u64> {
        tx.create_node_named(&[label::LANE_NODE], &self.props())
    }

    /// LaneNode `id`; `None` when there is no such node.
    ///
    /// # Errors
    /// The store fails, or the node lacks its lane_id or position.
    pub fn read(r: &impl GraphRead, id: u64) -> Result<Option<LaneNodeRecord>> {
        let Some(p) = Props::of(r, id, label::LANE_NODE)? else {
            return Ok(None);
        };
        Ok(Some(LaneNodeRecord {
            lane_id: p.need(key::LANE_ID, p.int(key::LANE_ID))?,
            kind: p.str(key::KIND).unwrap_or_default(),
            position: p.need(
                key::POSITION,
                p.get(key::POSITION).and_then(Value::as_point3),
            )?,
        }))
    }
}

/// A lane-graph edge (`LANE`).
#[derive(Debug, Clone, PartialEq)]
pub struct LaneEdgeRecord {
    /// Its length along the polyline, metres.
    pub length_m: f64,
    /// The driven path, world points.
    pub polyline: Vec<[f64; 3]>,
    /// The frames that drove it.
    pub frames: Vec<i64>,
    /// Whether it may be driven one way only.
    pub directed: bool,
}

impl LaneEdgeRecord {
    /// The relationship's properties: length_m, polyline, frames, directed.
    pub fn props(&self) -> Vec<(&'static str, Value)> {
        vec![
            (key::LENGTH_M, Value::Float(self.length_m)),
            (key::POLYLINE, points(&self.polyline)),
            (
                key::FRAMES,
                Value::List(self.frames.iter().map(|f| Value::Int(*f)).collect()),
            ),
            (key::DIRECTED, Value::Bool(self.directed)),
        ]
    }

    /// Creates the edge `from -[LANE]-> to`; returns its id.
    ///
    /// # Errors
    /// The store refuses the write.
    pub fn create(&self, tx: &mut WriteTxn<'_>, from: u64, to: u64) -> graphstore::Result<u64> {
        tx.create_rel_named(from, rel::LANE, to, &self.props())
    }

    /// Relationship `id` as a lane edge.
    ///
    /// # Errors
    /// The store fails, the relationship does not exist or has no length.
    pub fn read(r: &impl GraphRead, id: u64) -> Result<LaneEdgeRecord> {
        let p = rel_props(r, id)?;
        Ok(LaneEdgeRecord {
            length_m: match find(&p, key::LENGTH_M) {
                Some(Value::Float(x)) => *x,
                _ => return Err(Error::Invalid(format!("LANE {id} has no length_m"))),
            },
            polyline: points_of(find(&p, key::POLYLINE)),
            frames: match find(&p, key::FRAMES) {
                Some(Value::List(l)) => l.iter().filter_map(Value::as_int).collect(),
                _ => Vec::new(),
            },
            directed: find(&p, key::DIRECTED) == Some(&Value::Bool(true)),
        })
    }
}

/// An instance-layer relation (`RELATED`).
#[derive(Debug, Clone, PartialEq)]
pub struct RelationRecord {
    /// The relation (`next_to`, `on`, `under`, ... or an LLM's words).
    pub relation: String,
    /// The gap between the two boxes, metres.
    pub distance_m: f64,
    /// `geometric`, or the LLM pass that labelled it.
    pub source: String,
    /// How sure the source is, in [0, 1].
    pub confidence: f64,
}

/// `RELATED.source` of the relations the hierarchy derives from the boxes.
pub const GEOMETRIC: &str = "geometric";

impl RelationRecord {
    /// The relationship's properties: relation, distance_m, source, confidence.
    pub fn props(&self) -> Vec<(&'static str, Value)> {
        vec![
            (key::RELATION, self.relation.as_str().into()),
            (key::DISTANCE_M, Value::Float(self.distance_m)),
            (key::SOURCE, self.source.as_str().into()),
            (key::CONFIDENCE, Value::Float(self.confidence)),
        ]
    }

    /// Creates `a -[RELATED]-> b`; returns its id.
    ///
    /// # Errors
    /// The store refuses the write.
    pub fn create(&self, tx: &mut WriteTxn<'_>, a: u64, b: u64) -> graphstore::Result<u64> {
        tx.create_rel_named(a, rel::RELATED, b, &self.props())
    }

    /// Relationship `id` as a relation.
    ///
    /// # Errors
    /// The store fails, or the relationship lacks one of its properties.
    pub fn read(r: &impl GraphRead, id: u64) -> Result<RelationRecord> {
        let p = rel_props(r, id)?;
        let bad = |k: &str| Error::Invalid(format!("RELATED {id} has no valid {k}"));
        let float = |k: &str| match find(&p, k) {
            Some(Value::Float(x)) => Ok(*x),
            _ => Err(bad(k)),
        };
        let string = |k: &str| {
            find(&p, k)
                .and_then(Value::as_str)
                .map(str::to_string)
                .ok_or_else(|| bad(k))
        };
        Ok(RelationRecord {
            relation: string(key::RELATION)?,
            distance_m: float(key::DISTANCE_M)?,
            source: string(key::SOURCE)?,
            confidence: float(key::CONFIDENCE)?,
        })
    }
}

/// Membership of an instance or lane node in its segment (`IN_SEGMENT`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InSegmentRecord {
    /// How far outside the segment's area it lies, metres (0 inside).
    pub distance_m: f64,
}

impl InSegmentRecord {
    /// The relationship's properties: distance_m.
    pub fn props(&self) -> Vec<(&'static str, Value)> {
        vec![(key::DISTANCE_M, Value::Float(self.distance_m))]
    }

    /// Creates `member -[IN_SEGMENT]-> segment`; returns its id.
    ///
    /// # Errors
    /// The store refuses the write.
    pub fn create(
        &self,
        tx: &mut WriteTxn<'_>,
        member: u64,
        segment: u64,
    ) -> graphstore::Result<u64> {
        tx.create_rel_named(
            member,
            rel::IN_SEGMENT,
            segment,
            &[(key::DISTANCE_M, Value::Float(self.distance_m))],
        )
    }
}

/// A mapped object (`Instance`).
#[derive(Debug, Clone, PartialEq)]
pub struct InstanceRecord {
    /// The build's number for it (unique).
    pub instance_id: i64,
    /// Its caption.
    pub caption: String,
    /// Its SemanticKITTI class ([`key::SEMANTIC_CLASS`]), or `other-object`.
    pub semantic_class: String,
    /// Its open-vocabulary label ([`key::LABEL`]), when the build gave it one.
    pub label: Option<String>,
    /// The colour its captions agree on.
    pub colour: Option<String>,
    /// The material its captions agree on.
    pub material: Option<String>,
    /// Its centre, world metres.
    pub centroid: [f64; 3],
    /// Its axis-aligned box (min, max), world metres.
    pub bbox: ([f64; 3], [f64; 3]),
    /// Every caption seen, most recent last.
    pub captions: Option<Vec<String>>,
    /// The caption's sentence embedding.
    pub feature: Option<Vec<f32>>,
    /// Points fused.
    pub point_count: Option<i64>,
    /// Detections fused.
    pub detection_count: Option<i64>,
    /// First key frame it was seen in.
    pub first_frame: Option<i64>,
    /// Last key frame it was seen in.
    pub last_frame: Option<i64>,
    /// What produced it (`detections`, `oracle`, ...).
    pub source: Option<String>,
    /// The detections' own mean feature.
    pub detection_feature: Option<Vec<f32>>,
    /// Its oriented box on the ground plane.
    pub obb: Option<OrientedBox>,
    /// A ground surface's tile: (class id, tile x, tile z).
    pub tile: Option<[i64; 3]>,
}

impl InstanceRecord {
    /// The node's properties, in the order the build writes them.
    pub fn props(&self) -> Vec<(&'static str, Value)> {
        let (lo, hi) = self.bbox;
        let mut p = vec![
            (key::INSTANCE_ID, Value::Int(self.instance_id)),
            (key::CAPTION, self.caption.as_str().into()),
            (key::SEMANTIC_CLASS, self.semantic_class.as_str().into()),
            (key::CENTROID, Value::Point3D(self.centroid)),
            (key::BBOX, Value::box3d(lo, hi)),
        ];
        for (k, v) in [
            (key::LABEL, &self.label),
            (key::COLOUR, &self.colour),
            (key::MATERIAL, &self.material),
        ] {
            if let Some(v) = v {
                p.push((k, v.as_str().into()));
            }
        }
        if let Some(c) = &self.captions {
            p.push((
                key::CAPTIONS,
                Value::List(c.iter().cloned().map(Value::String).collect()),
            ));
        }
        if let Some(f) = &self.feature {
            p.push((key::FEATURE, Value::Vector(f.clone())));
        }
        for (k, v) in [
            (key::POINT_COUNT, self.point_count),
            (key::DETECTION_COUNT, self.detection_count),
            (key::FIRST_FRAME, self.first_frame),
            (key::LAST_FRAME, self.last_frame),
        ] {
            if let Some(v) = v {
                p.push((k, Value::Int(v)));
            }
        }
        if let Some(s) = &self.source {
            p.push((key::SOURCE, s.as_str().into()));
        }
        if let Some(f) = &self.detection_feature {
            p.push((key::DETECTION_FEATURE, Value::Vector(f.clone())));
        }
        if let Some(b) = &self.obb {
            p.push((key::OBB, obb_value(b)));
        }
        if let Some(t) = self.tile {
            p.push((key::TILE, Value::List(t.map(Value::Int).to_vec())));
        }
        p
    }

    /// Creates the node; returns its id.
    ///
    /// # Errors
    /// The store refuses the write.
    pub fn create(&self, tx: &mut WriteTxn<'_>) -> graphstore::Result<u64> {
        tx.create_node_named(&[label::INSTANCE], &self.props())
    }

    /// Instance node `id`; `None` when there is no such node.
    ///
    /// # Errors
    /// The store fails, or the node lacks a required property.
    pub fn read(r: &impl GraphRead, id: u64) -> Result<Option<InstanceRecord>> {
        let Some(p) = Props::of(r, id, label::INSTANCE)? else {
            return Ok(None);
        };
        Self::from_props(&p)
    }

    /// The properties [`InstanceRecord::read_for_view`] reads.
    pub const VIEW_KEYS: [&'static str; 9] = [
        key::INSTANCE_ID,
        key::CAPTION,
        key::SEMANTIC_CLASS,
        key::LEGACY_CLASS,
        key::LABEL,
        key::CENTROID,
        key::BBOX,
        key::FEATURE,
        key::TILE,
    ];

    /// [`InstanceRecord::read`] with only [`InstanceRecord::VIEW_KEYS`] decoded (what
    /// [`crate::view::MapView::load`] uses, read once per commit): the other fields are `None`
    /// (`captions`, `colour`, `material`, the counts, frames, `source`, `detection_feature`,
    /// `obb`) whatever the node holds.
    ///
    /// # Errors
    /// As [`InstanceRecord::read`].
    pub fn read_for_view(r: &impl GraphRead, id: u64) -> Result<Option<InstanceRecord>> {
        let Some(p) = Props::of_keys(r, id, label::INSTANCE, &Self::VIEW_KEYS)? else {
            return Ok(None);
        };
        Self::from_props(&p)
    }

    fn from_props<R: GraphRead>(p: &Props<'_, R>) -> Result<Option<InstanceRecord>> {
        let vector = |k: &str| p.get(k).and_then(Value::as_vector).map(<[f32]>::to_vec);
        Ok(Some(InstanceRecord {
            instance_id: p.need(key::INSTANCE_ID, p.int(key::INSTANCE_ID))?,
            caption: p.str(key::CAPTION).unwrap_or_default(),
            semantic_class: p
                .str(key::SEMANTIC_CLASS)
                .or_else(|| p.str(key::LEGACY_CLASS))
                .unwrap_or_default(),
            label: p.str(key::LABEL),
            colour: p.str(key::COLOUR),
            material: p.str(key::MATERIAL),
            centroid: p.need(
                key::CENTROID,
                p.get(key::CENTROID).and_then(Value::as_point3),
            )?,
            bbox: p.need(key::BBOX, p.get(key::BBOX).and_then(Value::as_box3d))?,
            captions: match p.get(key::CAPTIONS) {
                Some(Value::List(l)) => Some(
                    l.iter()
                        .filter_map(|v| v.as_str().map(str::to_string))
                        .collect(),
                ),
                _ => None,
            },
            feature: vector(key::FEATURE),
            point_count: p.int(key::POINT_COUNT),
            detection_count: p.int(key::DETECTION_COUNT),
            first_frame: p.int(key::FIRST_FRAME),
            last_frame: p.int(key::LAST_FRAME),
            source: p.str(key::SOURCE),
            detection_feature: vector(key::DETECTION_FEATURE),
            obb: p.get(key::OBB).and_then(obb_of),
            tile: match p.get(key::TILE) {
                Some(Value::List(l)) if l.len() == 3 => {
                    let v: Option<Vec<i64>> = l.iter().map(Value::as_int).collect();
                    v.map(|v| [v[0], v[1], v[2]])
                }
                _ => None,
            },
        }))
    }
}

/// An applied map edit (`MapEdit`).
#[derive(Debug, Clone, PartialEq)]
pub struct EditRecord {
    /// The described change.
    pub text: String,
    /// remove, move, change or add.
    pub kind: String,
    /// When it was applied, seconds since the Unix epoch.
    pub time_unix_s: f64,
    /// Whether it was undone.
    pub undone: bool,
    /// Which parser understood the text (`rules`, `llm`).
    pub parsed_by: Option<String>,
    /// A one-line summary.
    pub summary: Option<String>,
    /// The node ids it touched.
    pub touched: Vec<i64>,
    /// The instance it changed.
    pub target: Option<i64>,
    /// When it was undone.
    pub undone_unix_s: Option<f64>,
}

impl EditRecord {
    /// The node's properties: text, kind, time_unix_s, undone, then those it has of
    /// parsed_by and summary, touched, then target and undone_unix_s when it has them.
    pub fn props(&self) -> Vec<(&'static str, Value)> {
        let mut p = vec![
            (key::TEXT, self.text.as_str().into()),
            (key::KIND, self.kind.as_str().into()),
            (key::TIME_UNIX_S, Value::Float(self.time_unix_s)),
            (key::UNDONE, Value::Bool(self.undone)),
        ];
        if let Some(s) = &self.parsed_by {
            p.push((key::PARSED_BY, s.as_str().into()));
        }
        if let Some(s) = &self.summary {
            p.push((key::SUMMARY, s.as_str().into()));
        }
        p.push((
            key::TOUCHED,
            Value::List(self.touched.iter().map(|t| Value::Int(*t)).collect()),
        ));
        if let Some(t) = self.target {
            p.push((key::TARGET, Value::Int(t)));
        }
        if let Some(t) = self.undone_unix_s {
            p.push((key::UNDONE_UNIX_S, Value::Float(t)));
        }
        p
    }

    /// Creates the node; returns its id.
    ///
    /// # Errors
    /// The store refuses the write.
    pub fn create(&self, tx: &mut WriteTxn<'_>) -> graphstore::Result<u64> {
        tx.create_node_named(&[label::MAP_EDIT], &self.props())
    }

    /// MapEdit node `id`; `None` when there is no such node.
    ///
    /// # Errors
    /// The store fails, or the node lacks a required property.
    pub fn read(r: &impl GraphRead, id: u64) -> Result<Option<EditRecord>> {
        let Some(p) = Props::of(r, id, label::MAP_EDIT)? else {
            return Ok(None);
        };
        Ok(Some(EditRecord {
            text: p.need(key::TEXT, p.str(key::TEXT))?,
            kind: p.need(key::KIND, p.str(key::KIND))?,
            time_unix_s: p.need(key::TIME_UNIX_S, p.float(key::TIME_UNIX_S))?,
            undone: p.get(key::UNDONE) == Some(&Value::Bool(true)),
            parsed_by: p.str(key::PARSED_BY),
            summary: p.str(key::SUMMARY),
            touched: match p.get(key::TOUCHED) {
                Some(Value::List(l)) => l.iter().filter_map(Value::as_int).collect(),
                _ => Vec::new(),
            },
            target: p.int(key::TARGET),
            undone_unix_s: p.float(key::UNDONE_UNIX_S),
        }))
    }
}

/// Where the drive the map was built from starts and ends: the translation of the
/// `world_from_velo` pose of the `Frame` with the lowest and the highest `index`, world
/// frame, metres; `None` when the map has no frame with a pose.
///
/// # Errors
/// The store fails.
pub fn drive_ends(r: &impl GraphRead) -> Result<Option<([f64; 3], [f64; 3])>> {
    // (frame index, position) of the first and the last frame
    let mut first: Option<(i64, [f64; 3])> = None;
    let mut last: Option<(i64, [f64; 3])> = None;
    for id in r.nodes_with_label(label::FRAME)? {
        let Some(p) = Props::of(r, id, label::FRAME)? else {
            continue;
        };
        let (Some(index), Some(Value::List(pose))) =
            (p.int(key::INDEX), p.get(key::WORLD_FROM_VELO))
        else {
            continue;
        };
        let f: Vec<f64> = pose.iter().filter_map(Value::as_f64).collect();
        if f.len() != 12 || f.iter().any(|x| !x.is_finite()) {
            continue;
        }
        let at = (index, [f[3], f[7], f[11]]);
        if first.is_none_or(|a| at.0 < a.0) {
            first = Some(at);
        }
        if last.is_none_or(|b| at.0 > b.0) {
            last = Some(at);
        }
    }
    Ok(first.zip(last).map(|(a, b)| (a.1, b.1)))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use graphstore::Store;
    use proptest::prelude::*;

    fn p3() -> impl Strategy<Value = [f64; 3]> {
        prop::array::uniform3(-1000.0..1000.0f64)
    }

    fn word() -> impl Strategy<Value = String> {
        "[a-z_]{1,12}"
    }

    pub(crate) fn segment() -> impl Strategy<Value = SegmentRecord> {
        let shape = prop_oneof![
            Just(None),
            (0.5..50.0f64, prop::collection::vec(p3(), 0..6))
                .prop_map(|(radius_m, outline)| Some(SegmentShape::Disc { radius_m, outline })),
            (0.5..20.0f64, prop::collection::vec(p3(), 2..6)).prop_map(
                |(half_width_m, centerline)| Some(SegmentShape::Corridor {
                    half_width_m,
                    centerline
                })
            ),
        ];
        (
            0..1000i64,
            word(),
            p3(),
            shape,
            prop::option::of((p3(), p3())),
            prop::collection::vec(prop::collection::vec(p3(), 3..6), 0..3),
            prop::option::of(0.0..1e4f64),
        )
            .prop_map(|(segment_id, kind, centroid, shape, bbox, polygon, a)| {
                SegmentRecord {
                    segment_id,
                    kind,
                    centroid,
                    shape,
                    // a box is stored as (min, max)
                    bbox: bbox.map(|(a, b)| {
                        (
                            [0, 1, 2].map(|i| a[i].min(b[i])),
                            [0, 1, 2].map(|i| a[i].max(b[i])),
                        )
                    }),
                    polygon,
                    drivable_area_m2: a,
                }
            })
    }

    pub(crate) fn instance() -> impl Strategy<Value = InstanceRecord> {
        (
            (0..100_000i64, word(), word(), p3(), p3()),
            prop::option::of(prop::collection::vec(word(), 0..4)),
            prop::option::of(prop::collection::vec(-1.0..1.0f32, 384..=384)),
            (
                prop::option::of(0..1_000_000i64),
                prop::option::of(0..1000i64),
                prop::option::of(0..5000i64),
            ),
            prop::option::of(word()),
            prop::option::of(prop::array::uniform3(-100..100i64)),
        )
            .prop_map(
                |(
                    (instance_id, caption, class, c, half),
                    captions,
                    feature,
                    (n, d, f),
                    source,
                    tile,
                )| {
                    let half = half.map(f64::abs);
                    InstanceRecord {
                        instance_id,
                        caption,
                        semantic_class: class,
                        label: None,
                        colour: None,
                        material: None,
                        centroid: c,
                        bbox: (
                            [0, 1, 2].map(|i| c[i] - half[i]),
                            [0, 1, 2].map(|i| c[i] + half[i]),
                        ),
                        captions,
                        feature,
                        point_count: n,
                        detection_count: d,
                        first_frame: f,
                        last_frame: f.map(|f| f + 3),
                        source,
                        detection_feature: None,
                        obb: OrientedBox::from_values(&[c[0], c[2], 2.0, 1.0, 0.3, 0.0, 1.5]),
                        tile: tile.map(|[a, b, c]| [a.abs() % 20, b, c]),
                    }
                },
            )
    }

    fn edit() -> impl Strategy<Value = EditRecord> {
        (
            word(),
            word(),
            0.0..2e9f64,
            any::<bool>(),
            prop::option::of(word()),
            prop::option::of(word()),
            prop::collection::vec(0..1000i64, 0..4),
            prop::option::of(0..1000i64),
            prop::option::of(0.0..2e9f64),
        )
            .prop_map(
                |(text, kind, t, undone, parsed_by, summary, touched, target, u)| EditRecord {
                    text,
                    kind,
                    time_unix_s: t,
                    undone,
                    parsed_by,
                    summary,
                    touched,
                    target,
                    undone_unix_s: u,
                },
            )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Every record written through the store under the layer schema reads back equal,
        /// with the relationships between them.
        #[test]
        fn every_record_reads_back_as_written(
            seg in segment(),
            inst in instance(),
            ed in edit(),
            lane in (0..1000i64, word(), p3()),
            edge in (0.0..1e3f64, prop::collection::vec(p3(), 2..5), prop::collection::vec(0..5000i64, 0..4), any::<bool>()),
            relation in (word(), 0.0..30.0f64, word(), 0.0..=1.0f64),
            ground in prop_oneof![Just(GroundFrame::KittiCam), Just(GroundFrame::Enu)],
        ) {
            let dir = tempfile::tempdir().unwrap();
            let store = Store::create(dir.path().join("m.og")).unwrap();
            store.set_schema(crate::opengraph_schema()).unwrap();
            let env = EnvironmentRecord { name: "city".into(), source: Some("trajectory".into()), ground_frame: Some(ground) };
            let lane_a = LaneNodeRecord { lane_id: lane.0, kind: lane.1, position: lane.2 };
            let lane_b = LaneNodeRecord { lane_id: lane.0 + 1, ..lane_a.clone() };
            let le = LaneEdgeRecord { length_m: edge.0, polyline: edge.1, frames: edge.2, directed: edge.3 };
            let rr = RelationRecord { relation: relation.0, distance_m: relation.1, source: relation.2, confidence: relation.3 };
            let mut inst_b = inst.clone();
            inst_b.instance_id += 1;
            let ids = store.write(|tx| {
                let e = env.create(tx)?;
                let s = seg.create(tx)?;
                let (a, b) = (lane_a.create(tx)?, lane_b.create(tx)?);
                let l = le.create(tx, a, b)?;
                let (i, j) = (inst.create(tx)?, inst_b.create(tx)?);
                let rel = rr.create(tx, i, j)?;
                InSegmentRecord { distance_m: 1.5 }.create(tx, i, s)?;
                let m = ed.create(tx)?;
                Ok([e, s, a, b, l, i, j, rel, m])
            }).unwrap();
            let r = store.read().unwrap();
            prop_assert_eq!(EnvironmentRecord::read(&r, ids[0]).unwrap(), Some(env));
            prop_assert_eq!(ground_frame(&r).unwrap(), ground);
            prop_assert_eq!(SegmentRecord::read(&r, ids[1]).unwrap(), Some(seg.clone()));
            prop_assert_eq!(LaneNodeRecord::read(&r, ids[2]).unwrap(), Some(lane_a));
            prop_assert_eq!(LaneNodeRecord::read(&r, ids[3]).unwrap(), Some(lane_b));
            prop_assert_eq!(LaneEdgeRecord::read(&r, ids[4]).unwrap(), le);
            prop_assert_eq!(InstanceRecord::read(&r, ids[5]).unwrap(), Some(inst.clone()));
            prop_assert_eq!(InstanceRecord::read(&r, ids[6]).unwrap(), Some(inst_b));
            // the view's narrow read: its fields as written, the rest absent
            let narrow = InstanceRecord {
                captions: None,
                colour: None,
                material: None,
                point_count: None,
                detection_count: None,
                first_frame: None,
                last_frame: None,
                source: None,
                detection_feature: None,
                obb: None,
                ..inst.clone()
            };
            prop_assert_eq!(InstanceRecord::read_for_view(&r, ids[5]).unwrap(), Some(narrow));
            prop_assert_eq!(InstanceRecord::read_for_view(&r, ids[1]).unwrap(), None);
            prop_assert_eq!(RelationRecord::read(&r, ids[7]).unwrap(), rr);
            prop_assert_eq!(EditRecord::read(&r, ids[8]).unwrap(), Some(ed));
            // a node of another layer is not read as this one
            prop_assert_eq!(SegmentRecord::read(&r, ids[0]).unwrap(), None);
            prop_assert_eq!(InstanceRecord::read(&r, 1 << 40).unwrap(), None);
            // the ground areas follow the stored shape
            let area = seg.area(ground);
            match (&seg.shape, &area) {
                (None, SegmentArea::Disc { radius_m, .. }) => prop_assert_eq!(radius_m.to_bits(), DEFAULT_SEGMENT_RADIUS_M.to_bits()),
                (Some(SegmentShape::Disc { radius_m: a, .. }), SegmentArea::Disc { radius_m: b, .. }) => prop_assert_eq!(a.to_bits(), b.to_bits()),
                (Some(SegmentShape::Corridor { centerline, .. }), SegmentArea::Corridor { centreline, .. }) => prop_assert_eq!(centerline.len(), centreline.len()),
                other => prop_assert!(false, "shape and area disagree: {other:?}"),
            }
            prop_assert_eq!(seg.drivable(ground).is_some(), !seg.polygon.is_empty());
        }
    }
}
