//! The OpenGraph layer schema: what the store enforces on every write to a map (labels and
//! their typed properties, relationship types and their ends, property, spatial, vector and
//! text indexes). `docs/schema.md` documents every name.

use graphstore::{
    LabelRule, PropertyIndexSpec, PropertyRule, RelRule, Schema, SpatialIndexSpec, TextIndexSpec,
    ValueType, VectorIndexSpec, VectorMethod,
};

use crate::names::{index, key, label, rel};

fn req(key: &str, ty: ValueType) -> PropertyRule {
    PropertyRule {
        key: key.into(),
        ty,
        required: true,
    }
}

fn opt(key: &str, ty: ValueType) -> PropertyRule {
    PropertyRule {
        key: key.into(),
        ty,
        required: false,
    }
}

fn rel(from: &[&str], to: &[&str], properties: Vec<PropertyRule>, description: &str) -> RelRule {
    RelRule {
        properties,
        from_labels: from.iter().map(|s| s.to_string()).collect(),
        to_labels: to.iter().map(|s| s.to_string()).collect(),
        description: description.into(),
    }
}

/// Dimension of the sentence-embedding features (all-MiniLM-L6-v2).
pub const FEATURE_DIM: usize = 384;

/// The OpenGraph layers as a schema. `docs/schema.md` documents every name here.
pub fn opengraph_schema() -> Schema {
    use ValueType as T;
    let mut s = Schema::default();
    s.labels.insert(
        label::ENVIRONMENT.into(),
        LabelRule {
            properties: vec![
                req(key::NAME, T::String),
                opt(key::SOURCE, T::String),
                opt(key::GROUND_FRAME, T::String),
            ],
            unique: vec![key::NAME.into()],
            description: "Root of the hierarchy: one per mapped environment.".into(),
        },
    );
    s.labels.insert(
        label::SEGMENT.into(),
        LabelRule {
            properties: vec![
                req(key::SEGMENT_ID, T::Int),
                req(key::KIND, T::String),
                req(key::CENTROID, T::Point3D),
                opt(key::AREA, T::List),
                opt(key::RADIUS_M, T::Float),
                opt(key::CENTERLINE, T::List),
                opt(key::HALF_WIDTH_M, T::Float),
                opt(key::BBOX, T::Box3D),
                opt(key::POLYGON, T::List),
                opt(key::DRIVABLE_AREA_M2, T::Float),
            ],
            unique: vec![key::SEGMENT_ID.into()],
            description:
                "Road segment: intersection, t_intersection, l_intersection or straight_roadway; polygon is its drivable area measured from the map (rings of points, even-odd)."
                    .into(),
        },
    );
    s.labels.insert(
        label::LANE_NODE.into(),
        LabelRule {
            properties: vec![
                req(key::LANE_ID, T::Int),
                req(key::KIND, T::String),
                req(key::POSITION, T::Point3D),
            ],
            unique: vec![key::LANE_ID.into()],
            description:
                "Lane-graph vertex: intersection, t_intersection, l_intersection or breakpoint."
                    .into(),
        },
    );
    s.labels.insert(
        label::INSTANCE.into(),
        LabelRule {
            properties: vec![
                req(key::INSTANCE_ID, T::Int),
                req(key::CAPTION, T::String),
                req(key::SEMANTIC_CLASS, T::String),
                req(key::CENTROID, T::Point3D),
                req(key::BBOX, T::Box3D),
                opt(key::LABEL, T::String),
                opt(key::COLOUR, T::String),
                opt(key::MATERIAL, T::String),
                opt(key::CAPTIONS, T::List),
                opt(key::FEATURE, T::Vector),
                opt(key::POINT_COUNT, T::Int),
                opt(key::DETECTION_COUNT, T::Int),
                opt(key::FIRST_FRAME, T::Int),
                opt(key::LAST_FRAME, T::Int),
                opt(key::SOURCE, T::String),
                opt(key::DETECTION_FEATURE, T::Vector),
                opt(key::TILE, T::List),
                opt(key::OBB, T::List),
            ],
            unique: vec![key::INSTANCE_ID.into()],
            description: "A mapped object with label (what it is, in words: one label per kind of object across the map), caption, feature, semantic_class (the SemanticKITTI class for segmentation, or other-object), colour and material when its captions agree, box and points; obb is its oriented box on the ground plane: [center_0, center_1, half_length_m, half_width_m, yaw_rad, bottom_m, top_m] in the environment's ground frame.".into(),
        },
    );
    s.labels.insert(
        label::FRAME.into(),
        LabelRule {
            properties: vec![
                req(key::INDEX, T::Int),
                req(key::WORLD_FROM_VELO, T::List),
                opt(key::TIMESTAMP_SECS, T::Float),
            ],
            unique: vec![key::INDEX.into()],
            description: "A key frame with its pose (3x4 row-major, 12 floats).".into(),
        },
    );
    s.labels.insert(
        label::BUILD.into(),
        LabelRule {
            properties: vec![
                req(key::BUILD_ID, T::Int),
                req(key::ARGS, T::String),
                req(key::NEXT_FRAME, T::Int),
                req(key::NEXT_INSTANCE_ID, T::Int),
                req(key::FINISHED, T::Bool),
                opt(key::HIERARCHY_DONE, T::Bool),
                opt(key::SOURCE, T::String),
                opt(key::LAST_STAMP_NS, T::Int),
                opt(key::TRAJECTORY, T::List),
            ],
            unique: vec![key::BUILD_ID.into()],
            description:
                "Provenance and checkpoint of a map build (lets `build --resume` continue).".into(),
        },
    );
    s.labels.insert(
        label::MAP_EDIT.into(),
        LabelRule {
            properties: vec![
                req(key::TEXT, T::String),
                req(key::KIND, T::String),
                req(key::TIME_UNIX_S, T::Float),
                req(key::UNDONE, T::Bool),
                opt(key::PARSED_BY, T::String),
                opt(key::SUMMARY, T::String),
                opt(key::TOUCHED, T::List),
                opt(key::TARGET, T::Int),
                opt(key::UNDONE_UNIX_S, T::Float),
            ],
            unique: vec![],
            description: "An applied map edit (remove, move, change, add) from a described change; its `diff` payload lets `update --undo` revert it exactly.".into(),
        },
    );
    s.relationships.insert(
        rel::CONTAINS.into(),
        rel(
            &[label::ENVIRONMENT],
            &[label::SEGMENT],
            vec![],
            "Environment to each of its segments.",
        ),
    );
    s.relationships.insert(
        rel::CONNECTS.into(),
        rel(
            &[label::SEGMENT],
            &[label::SEGMENT],
            vec![],
            "Traversable adjacency between segments.",
        ),
    );
    s.relationships.insert(
        rel::LANE.into(),
        rel(
            &[label::LANE_NODE],
            &[label::LANE_NODE],
            vec![
                req(key::LENGTH_M, T::Float),
                opt(key::POLYLINE, T::List),
                opt(key::FRAMES, T::List),
                opt(key::DIRECTED, T::Bool),
            ],
            "Lane-graph edge with its metric polyline.",
        ),
    );
    s.relationships.insert(
        rel::IN_SEGMENT.into(),
        rel(
            &[label::INSTANCE, label::LANE_NODE],
            &[label::SEGMENT],
            vec![opt(key::DISTANCE_M, T::Float)],
            "Membership in the closest segment.",
        ),
    );
    s.relationships.insert(
        rel::RELATED.into(),
        rel(
            &[label::INSTANCE],
            &[label::INSTANCE],
            vec![
                req(key::RELATION, T::String),
                req(key::DISTANCE_M, T::Float),
                req(key::SOURCE, T::String),
                req(key::CONFIDENCE, T::Float),
            ],
            "Instance-layer relation (geometric or LLM-inferred).",
        ),
    );
    s.relationships.insert(
        rel::OBSERVED_IN.into(),
        rel(
            &[label::INSTANCE],
            &[label::FRAME],
            vec![opt(key::DETECTIONS, T::Int)],
            "Instance seen in a key frame.",
        ),
    );
    s.property_indexes = vec![
        PropertyIndexSpec {
            name: None,
            label: label::INSTANCE.into(),
            key: key::SEMANTIC_CLASS.into(),
        },
        PropertyIndexSpec {
            name: None,
            label: label::INSTANCE.into(),
            key: key::LABEL.into(),
        },
        PropertyIndexSpec {
            name: None,
            label: label::LANE_NODE.into(),
            key: key::KIND.into(),
        },
        PropertyIndexSpec {
            name: None,
            label: label::SEGMENT.into(),
            key: key::KIND.into(),
        },
    ];
    s.spatial_indexes = vec![
        SpatialIndexSpec {
            name: index::INSTANCE_SPACE.into(),
            label: label::INSTANCE.into(),
            position_key: key::CENTROID.into(),
            box_key: Some(key::BBOX.into()),
        },
        SpatialIndexSpec {
            name: index::LANE_SPACE.into(),
            label: label::LANE_NODE.into(),
            position_key: key::POSITION.into(),
            box_key: None,
        },
        SpatialIndexSpec {
            name: index::SEGMENT_SPACE.into(),
            label: label::SEGMENT.into(),
            position_key: key::CENTROID.into(),
            box_key: Some(key::BBOX.into()),
        },
    ];
    s.vector_indexes = vec![VectorIndexSpec {
        name: index::INSTANCE_FEATURE.into(),
        label: label::INSTANCE.into(),
        key: key::FEATURE.into(),
        dim: FEATURE_DIM,
        int8: true,
        method: VectorMethod::Flat,
    }];
    s.text_indexes = vec![TextIndexSpec {
        name: index::INSTANCE_CAPTION.into(),
        label: label::INSTANCE.into(),
        key: key::CAPTION.into(),
    }];
    s
}

/// What one declared property means, with its unit and frame, for agents reading the schema
/// (`get_schema`); `owner` is a node label or a relationship type. None for a name the
/// OpenGraph schema does not declare. `docs/schema.md` says the same for people.
pub fn property_meaning(owner: &str, property: &str) -> Option<&'static str> {
    const WORLD: &str = "point3d, metres, world frame (see `frame`: which axes are the ground)";
    Some(match (owner, property) {
        (label::ENVIRONMENT, key::NAME) => "the environment's name",
        (label::ENVIRONMENT, key::SOURCE) => "what the hierarchy was built from",
        (label::ENVIRONMENT, key::GROUND_FRAME) => {
            "kitti_cam (ground is world x and z, up is -y: KITTI's camera y points down) or enu (ground is x and y, up is +z)"
        }
        (label::SEGMENT, key::SEGMENT_ID) => {
            "the hierarchy's own segment number (provenance); tools take the node id, id(s)"
        }
        (label::SEGMENT, key::KIND) => {
            "intersection (crossroads), t_intersection, l_intersection (bend) or straight_roadway"
        }
        (label::SEGMENT, key::CENTROID) => WORLD,
        (label::SEGMENT, key::AREA) => {
            "outline polygon of a junction, a list of point3d (world frame, metres)"
        }
        (label::SEGMENT, key::RADIUS_M) => {
            "radius of a junction's disc around the centroid, metres"
        }
        (label::SEGMENT, key::CENTERLINE) => {
            "a road's centre line, a list of point3d (world frame, metres)"
        }
        (label::SEGMENT, key::HALF_WIDTH_M) => "half the width of a road's corridor, metres",
        (label::SEGMENT | label::INSTANCE, key::BBOX) => {
            "axis-aligned box [min, max], two point3d, metres, world frame"
        }
        (label::SEGMENT, key::POLYGON) => {
            "drivable area measured from the map: rings of point3d (even-odd), metres, world frame"
        }
        (label::SEGMENT, key::DRIVABLE_AREA_M2) => "area of the drivable polygon, square metres",
        (label::LANE_NODE, key::LANE_ID) => {
            "the lane graph's own vertex number (provenance); tools take the node id, id(l), or lane:ID with the node id"
        }
        (label::LANE_NODE, key::KIND) => {
            "intersection, t_intersection, l_intersection or breakpoint"
        }
        (label::LANE_NODE, key::POSITION) => WORLD,
        (label::INSTANCE, key::INSTANCE_ID) => {
            "the mapping's own object number (provenance); tools take the node id, id(n)"
        }
        (label::INSTANCE, key::CAPTION) => {
            "a sentence describing the object (the medoid of its captions)"
        }
        (label::INSTANCE, key::SEMANTIC_CLASS) => {
            "the SemanticKITTI class for segmentation (car, pole, vegetation, ...; other-object when none fits); use label for what the object is"
        }
        (label::INSTANCE, key::LABEL) => {
            "what the object is, in words (fire hydrant, post box, bus stop shelter): one label per kind of object across the map"
        }
        (label::INSTANCE, key::COLOUR) => "its colour, where its captions agree",
        (label::INSTANCE, key::MATERIAL) => "its material, where its captions agree",
        (label::INSTANCE, key::CAPTIONS) => "every caption it was given, a list of strings",
        (label::INSTANCE, key::FEATURE) => {
            "384-d sentence embedding (all-MiniLM-L6-v2) of caption and detections, unit length; summarised in whole-node answers"
        }
        (label::INSTANCE, key::CENTROID) => WORLD,
        (label::INSTANCE, key::POINT_COUNT) => "LiDAR points kept (one per 0.1 m voxel)",
        (label::INSTANCE, key::DETECTION_COUNT) => "detections fused into it",
        (label::INSTANCE, key::FIRST_FRAME) | (label::INSTANCE, key::LAST_FRAME) => {
            "first / last key frame it was seen in (Frame.index)"
        }
        (label::INSTANCE, key::SOURCE) => "oracle, detector or simulator: which perception made it",
        (label::INSTANCE, key::DETECTION_FEATURE) => {
            "running mean of its detections' features, 384-d"
        }
        (label::INSTANCE, key::TILE) => "[class id, tile x, tile z] for ground-surface tiles only",
        (label::INSTANCE, key::OBB) => {
            "oriented box on the ground plane: [centre 0, centre 1, half length m, half width m, yaw rad, bottom m, top m] in the ground frame"
        }
        (label::FRAME, key::INDEX) => "the key frame's index in the sequence",
        (label::FRAME, key::WORLD_FROM_VELO) => {
            "pose: 3x4 row-major, 12 floats, LiDAR frame to world frame, metres"
        }
        (label::FRAME, key::TIMESTAMP_SECS) => "sensor time, seconds",
        (label::BUILD, key::BUILD_ID) => "the build's number",
        (label::BUILD, key::ARGS) => "JSON: sequence, source, frames, stride and mapping config",
        (label::BUILD, key::NEXT_FRAME) => "the frame `build --resume` continues from",
        (label::BUILD, key::NEXT_INSTANCE_ID) => "the next instance_id the mapping will give",
        (label::BUILD, key::FINISHED) => "whether the build ran to its end",
        (label::BUILD, key::HIERARCHY_DONE) => "whether the hierarchy was built over it",
        (label::BUILD, key::SOURCE) => "oracle, detector or simulator: which perception it used",
        (label::BUILD, key::LAST_STAMP_NS) => {
            "a live build's last committed cloud stamp, nanoseconds"
        }
        (label::BUILD, key::TRAJECTORY) => {
            "a live build's LiDAR positions so far, a flat list of x, y, z (world frame, metres)"
        }
        (label::MAP_EDIT, key::PARSED_BY) => "rules, or the language model that read the change",
        (label::MAP_EDIT, key::SUMMARY) => "what the edit did, in words",
        (label::MAP_EDIT, key::UNDONE_UNIX_S) => "when it was undone, Unix seconds",
        (label::MAP_EDIT, key::TEXT) => "the described change",
        (label::MAP_EDIT, key::KIND) => "remove, move, change or add",
        (label::MAP_EDIT, key::TIME_UNIX_S) => "when it was applied, Unix seconds",
        (label::MAP_EDIT, key::UNDONE) => "whether it was undone",
        (label::MAP_EDIT, key::TOUCHED) => "the node ids it changed",
        (label::MAP_EDIT, key::TARGET) => "the node id it acted on",
        (rel::LANE, key::LENGTH_M) => {
            "length of the lane edge along its polyline, metres; LANE is stored one way and travelled both ways: match it undirected, -[:LANE]-"
        }
        (rel::LANE, key::POLYLINE) => "the edge's path, a list of point3d (world frame, metres)",
        (rel::LANE, key::FRAMES) => "the key frames the drive passed along it",
        (rel::LANE, key::DIRECTED) => "true when only one way was driven",
        (rel::IN_SEGMENT, key::DISTANCE_M) => {
            "ground-plane distance from the node to the segment's area, metres (0: inside; more: its nearest segment lies that far away)"
        }
        (rel::RELATED, key::RELATION) => {
            "on, under, next_to, near, in_front_of, behind, left_of, right_of, inside (geometric), or an LLM's phrase"
        }
        (rel::RELATED, key::DISTANCE_M) => "gap between the two boxes, metres",
        (rel::RELATED, key::SOURCE) => "geometric or llm",
        (rel::RELATED, key::CONFIDENCE) => "0 to 1",
        (rel::OBSERVED_IN, key::DETECTIONS) => "detections of the object in that frame",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opengraph_schema_is_valid_and_roundtrips() {
        let s = opengraph_schema();
        s.validate().unwrap();
        let json = serde_json::to_string(&s).unwrap();
        let back: Schema = serde_json::from_str(&json).unwrap();
        assert_eq!(back, s);
        let idx = s.effective_property_indexes();
        assert!(idx.iter().any(|i| i.label == "Frame" && i.key == "index"));
        assert!(
            idx.iter()
                .any(|i| i.label == "Instance" && i.key == "semantic_class")
        );
    }

    #[test]
    fn duplicate_index_names_are_rejected() {
        let mut s = opengraph_schema();
        s.text_indexes.push(TextIndexSpec {
            name: "instance_feature".into(),
            label: "X".into(),
            key: "y".into(),
        });
        assert!(s.validate().is_err());
    }
}
