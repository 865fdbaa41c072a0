//! The prompts, one file per task in `llm_tools/prompts/`, each with a version. A prompt's
//! text never changes under the same version: change the text, bump the version (and the file
//! name), so that every LLM-made fact records which prompt made it and cached answers of an
//! older prompt are never reused.

/// A versioned system prompt.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Prompt {
    /// Task name (`merge_captions`, `relation`).
    pub task: &'static str,
    /// Version, bumped on every change of the text.
    pub version: u32,
    /// The system prompt.
    pub text: &'static str,
}

impl Prompt {
    /// `task@vN`, as recorded with each fact.
    pub fn id(&self) -> String {
        format!("{}@v{}", self.task, self.version)
    }
}

/// Merges the captions of one object's detections (the paper's LLM caption merge): the
/// numbered captions in, one caption out. Measured on the default small city with
/// Qwen2.5-Coder-0.5B, this plain form kept colours and materials better than two variants
/// that had the model first state the majority colour, kind and material (docs/llm.md).
pub const MERGE_CAPTIONS: Prompt = Prompt {
    task: "merge_captions",
    version: 1,
    text: include_str!("../prompts/merge_captions.v1.txt"),
};

/// Labels the relation between two objects from their captions and boxes (the paper's LLM
/// relation inference). v2 gives facts measured on the boxes (within, on top, gap) beside the
/// boxes themselves; with v1 (boxes only) Qwen2.5-Coder-0.5B answered "inside" for every pair.
/// v3 asks for the relation before the confidence (v2's schema put the confidence first).
pub const RELATION: Prompt = Prompt {
    task: "relation",
    version: 3,
    text: include_str!("../prompts/relation.v3.txt"),
};

/// Parses a request about the map into the structured form of `request::Request`. v2 adds
/// five worked examples with the keys in the order the grammar asks them (sorted by name):
/// with v1 (no examples) Qwen2.5-Coder 0.5B and 1.5B filled every field, inventing anchors,
/// segments and ordinals.
pub const PARSE_REQUEST: Prompt = Prompt {
    task: "parse_request",
    version: 2,
    text: include_str!("../prompts/parse_request.v2.txt"),
};

/// Parses a report of a change to the map ("the bush under the street sign is gone") into
/// `edit::EditRequest`'s form, with five worked examples in the grammar's key order.
pub const PARSE_EDIT: Prompt = Prompt {
    task: "parse_edit",
    version: 1,
    text: include_str!("../prompts/parse_edit.v1.txt"),
};

/// Picks the best candidates for a request from their captions and evidence (OpenGraph-LLM
/// re-ranking).
pub const RERANK: Prompt = Prompt {
    task: "rerank",
    version: 1,
    text: include_str!("../prompts/rerank.v1.txt"),
};

/// The agent behind `opengraph ask`: answer questions about the map by calling its tools.
pub const ASK: Prompt = Prompt {
    task: "ask",
    version: 1,
    text: include_str!("../prompts/ask.v1.txt"),
};

/// Turns a question about the map into one task (`request::question::Task`, in the flat
/// form of `request::question::task_form_schema`), with worked examples in the grammar's
/// key order; the task is run with the service's tools and the answer composed from their
/// result, not generated. v2 (from v1's errors on the tuning half of the generated
/// questions, Qwen2.5-Coder 0.5B: segment kinds left null, "in segment:ID" read as a segment
/// count, "driving distance" as a straight-line distance) says what each action covers and
/// adds three examples of those forms.
pub const ASK_TASK: Prompt = Prompt {
    task: "ask_task",
    version: 2,
    text: include_str!("../prompts/ask_task.v2.txt"),
};

/// The blind baseline of `opengraph ask --blind`: the model answers a question about the map
/// without its tools (it cannot see the map), with a short answer and a checkable value, so
/// that what the tools add can be measured.
pub const ASK_BLIND: Prompt = Prompt {
    task: "ask_blind",
    version: 1,
    text: include_str!("../prompts/ask_blind.v1.txt"),
};

/// The JSON Schema of a merged caption.
pub fn merge_captions_schema() -> serde_json::Value {
    serde_json::json!({"type": "object",
        "properties": {"caption": {"type": "string", "minLength": 3, "maxLength": 140}},
        "required": ["caption"], "additionalProperties": false})
}

/// The JSON Schema of a relation label: the relation, then the confidence (names sorted in
/// that order: the grammar follows the order of `properties`, and `serde_json` keeps them
/// sorted by name).
pub fn relation_schema() -> serde_json::Value {
    serde_json::json!({"type": "object",
        "properties": {"relation": {"type": "string", "minLength": 2, "maxLength": 40},
                       "relation_confidence": {"type": "number", "minimum": 0, "maximum": 1}},
        "required": ["relation", "relation_confidence"], "additionalProperties": false})
}
