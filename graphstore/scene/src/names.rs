//! The names of the map model in the store: node labels, relationship types, property keys
//! and index names. Every crate spells them through these constants; `docs/schema.md`
//! documents each.

/// Node labels, one per layer of the hierarchy (and the build's and the LLM's records).
pub mod label {
    /// Root of the hierarchy: one per mapped environment.
    pub const ENVIRONMENT: &str = "Environment";
    /// A road segment: crossroads, T-junction, bend or straight road.
    pub const SEGMENT: &str = "Segment";
    /// A lane-graph vertex.
    pub const LANE_NODE: &str = "LaneNode";
    /// A mapped object.
    pub const INSTANCE: &str = "Instance";
    /// A key frame with its pose.
    pub const FRAME: &str = "Frame";
    /// Provenance and checkpoint of a map build.
    pub const BUILD: &str = "Build";
    /// An applied map edit.
    pub const MAP_EDIT: &str = "MapEdit";
    /// A cached answer of an LLM pass over the map.
    pub const LLM_ANSWER: &str = "LlmAnswer";
}

/// Relationship types.
pub mod rel {
    /// Environment to each of its segments.
    pub const CONTAINS: &str = "CONTAINS";
    /// Traversable adjacency between segments.
    pub const CONNECTS: &str = "CONNECTS";
    /// A lane-graph edge.
    pub const LANE: &str = "LANE";
    /// An instance's or lane node's closest segment.
    pub const IN_SEGMENT: &str = "IN_SEGMENT";
    /// An instance-layer relation (geometric or LLM-inferred).
    pub const RELATED: &str = "RELATED";
    /// An instance seen in a key frame.
    pub const OBSERVED_IN: &str = "OBSERVED_IN";
}

/// Property keys.
pub mod key {
    /// `Environment.name`.
    pub const NAME: &str = "name";
    /// Where a node came from (`Environment`, `Instance`, `Build`, `RELATED`).
    pub const SOURCE: &str = "source";
    /// `Environment.ground_frame`: `kitti_cam` or `enu`.
    pub const GROUND_FRAME: &str = "ground_frame";
    /// `Segment.segment_id`.
    pub const SEGMENT_ID: &str = "segment_id";
    /// `Segment.kind`, `LaneNode.kind`, `MapEdit.kind`.
    pub const KIND: &str = "kind";
    /// `Segment.centroid`, `Instance.centroid` (point3d, world metres).
    pub const CENTROID: &str = "centroid";
    /// `Segment.area`.
    pub const AREA: &str = "area";
    /// `Segment.radius_m`.
    pub const RADIUS_M: &str = "radius_m";
    /// `Segment.centerline`.
    pub const CENTERLINE: &str = "centerline";
    /// `Segment.half_width_m`.
    pub const HALF_WIDTH_M: &str = "half_width_m";
    /// `Segment.bbox`, `Instance.bbox` (box3d, world metres).
    pub const BBOX: &str = "bbox";
    /// `Segment.polygon`: the drivable area's rings.
    pub const POLYGON: &str = "polygon";
    /// `Segment.drivable_area_m2`.
    pub const DRIVABLE_AREA_M2: &str = "drivable_area_m2";
    /// `LaneNode.lane_id`.
    pub const LANE_ID: &str = "lane_id";
    /// `LaneNode.position` (point3d, world metres).
    pub const POSITION: &str = "position";
    /// `Instance.instance_id`.
    pub const INSTANCE_ID: &str = "instance_id";
    /// `Instance.caption`.
    pub const CAPTION: &str = "caption";
    /// `Instance.semantic_class`: a SemanticKITTI class name (the segmentation vocabulary),
    /// or `other-object` when none of the 19 fits the object's label.
    pub const SEMANTIC_CLASS: &str = "semantic_class";
    /// `Instance.class`: where maps built before 2026-12-04 kept the SemanticKITTI class;
    /// read when a node has no [`SEMANTIC_CLASS`].
    pub const LEGACY_CLASS: &str = "class";
    /// `Instance.label`: the open-vocabulary label, the noun phrase its captions name it by,
    /// one per kind of object across the map ("post box", "fire hydrant").
    pub const LABEL: &str = "label";
    /// `Instance.colour`: the colour its captions agree on ("red"), when they do.
    pub const COLOUR: &str = "colour";
    /// `Instance.material`: the material its captions agree on ("metal"), when they do.
    pub const MATERIAL: &str = "material";
    /// `Instance.captions`: every caption seen.
    pub const CAPTIONS: &str = "captions";
    /// `Instance.feature`: the caption's sentence embedding.
    pub const FEATURE: &str = "feature";
    /// `Instance.point_count`.
    pub const POINT_COUNT: &str = "point_count";
    /// `Instance.detection_count`.
    pub const DETECTION_COUNT: &str = "detection_count";
    /// `Instance.first_frame`.
    pub const FIRST_FRAME: &str = "first_frame";
    /// `Instance.last_frame`.
    pub const LAST_FRAME: &str = "last_frame";
    /// `Instance.detection_feature`.
    pub const DETECTION_FEATURE: &str = "detection_feature";
    /// `Instance.tile`.
    pub const TILE: &str = "tile";
    /// `Instance.obb`: the oriented box on the ground plane.
    pub const OBB: &str = "obb";
    /// `Frame.index`.
    pub const INDEX: &str = "index";
    /// `Frame.world_from_velo`: 3x4 row-major pose.
    pub const WORLD_FROM_VELO: &str = "world_from_velo";
    /// `Frame.timestamp_secs`.
    pub const TIMESTAMP_SECS: &str = "timestamp_secs";
    /// `Build.build_id`.
    pub const BUILD_ID: &str = "build_id";
    /// `Build.args`: the build's arguments as JSON.
    pub const ARGS: &str = "args";
    /// `Build.next_frame`: where a resumed build goes on.
    pub const NEXT_FRAME: &str = "next_frame";
    /// `Build.next_instance_id`.
    pub const NEXT_INSTANCE_ID: &str = "next_instance_id";
    /// `Build.finished`.
    pub const FINISHED: &str = "finished";
    /// `Build.hierarchy_done`.
    pub const HIERARCHY_DONE: &str = "hierarchy_done";
    /// `Build.last_stamp_ns`: a live build's last committed cloud stamp (nanoseconds).
    pub const LAST_STAMP_NS: &str = "last_stamp_ns";
    /// `Build.trajectory`: a live build's poses so far, as `[x, y, z]` world positions of
    /// the LiDAR (a flat list, three numbers a pose), for the hierarchy after a restart.
    pub const TRAJECTORY: &str = "trajectory";
    /// `LANE.length_m`.
    pub const LENGTH_M: &str = "length_m";
    /// `LANE.polyline`.
    pub const POLYLINE: &str = "polyline";
    /// `LANE.frames`.
    pub const FRAMES: &str = "frames";
    /// `LANE.directed`.
    pub const DIRECTED: &str = "directed";
    /// `IN_SEGMENT.distance_m`, `RELATED.distance_m`.
    pub const DISTANCE_M: &str = "distance_m";
    /// `RELATED.relation`.
    pub const RELATION: &str = "relation";
    /// `RELATED.confidence`.
    pub const CONFIDENCE: &str = "confidence";
    /// `OBSERVED_IN.detections`.
    pub const DETECTIONS: &str = "detections";
    /// `MapEdit.text`.
    pub const TEXT: &str = "text";
    /// `MapEdit.time_unix_s`.
    pub const TIME_UNIX_S: &str = "time_unix_s";
    /// `MapEdit.undone`.
    pub const UNDONE: &str = "undone";
    /// `MapEdit.parsed_by`.
    pub const PARSED_BY: &str = "parsed_by";
    /// `MapEdit.summary`.
    pub const SUMMARY: &str = "summary";
    /// `MapEdit.touched`.
    pub const TOUCHED: &str = "touched";
    /// `MapEdit.target`.
    pub const TARGET: &str = "target";
    /// `MapEdit.undone_unix_s`.
    pub const UNDONE_UNIX_S: &str = "undone_unix_s";
    /// `LlmAnswer.key`: what the cached answer answers (a hash of the question).
    pub const KEY: &str = "key";
    /// `LlmAnswer.answer`: the model's answer (JSON text).
    pub const ANSWER: &str = "answer";
    /// `LlmAnswer.model`, `RELATED.model`: the language model that made the fact.
    pub const MODEL: &str = "model";
    /// `LlmAnswer.prompt`, `RELATED.prompt`: the prompt and its version (`merge_captions@v1`).
    pub const PROMPT: &str = "prompt";
    /// `Instance.caption_medoid`: the medoid caption kept beside an LLM-merged one.
    pub const CAPTION_MEDOID: &str = "caption_medoid";
    /// `Instance.caption_model`: the model that merged the caption.
    pub const CAPTION_MODEL: &str = "caption_model";
    /// `Instance.caption_prompt`: the prompt that merged the caption.
    pub const CAPTION_PROMPT: &str = "caption_prompt";
}

/// Payload names (bytes kept beside a node, outside its properties).
pub mod payload {
    /// An instance's fused points (a `graphstore::PointCloud`, world frame, metres).
    pub const POINTS: &str = "points";
    /// A `MapEdit`'s undo record.
    pub const DIFF: &str = "diff";
}

/// Index names.
pub mod index {
    /// Spatial index over instances' boxes.
    pub const INSTANCE_SPACE: &str = "instance_space";
    /// Spatial index over lane nodes' positions.
    pub const LANE_SPACE: &str = "lane_space";
    /// Spatial index over segments' boxes.
    pub const SEGMENT_SPACE: &str = "segment_space";
    /// Vector index over instances' features.
    pub const INSTANCE_FEATURE: &str = "instance_feature";
    /// Full-text index over instances' captions.
    pub const INSTANCE_CAPTION: &str = "instance_caption";
}
