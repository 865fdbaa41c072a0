//! The map's language-model passes (paper: "LLaMA merges the captions of an object's
//! detections" and "captions, poses and boxes of object pairs go into an LLM to infer their
//! relations"), run over a built map, resumable, with every answer cached in the map.
//!
//! - [`merge_captions`]: each object's latest captions become one caption that keeps what they
//!   agree on (post-processing, once per final instance, not once per frame). The medoid
//!   caption stays as `caption_medoid`; `caption_model` and `caption_prompt` record who wrote
//!   the new one, and the instance's feature is recomputed from it.
//! - [`infer_relations`]: for the instance layer's spanning-tree edges and close pairs among
//!   objects (never road, sidewalk, parking, terrain or other-ground surfaces), an
//!   open-vocabulary relation with a confidence, written as
//!   `RELATED {source: "llm", relation, confidence, model, prompt, distance_m}` beside the
//!   geometric edges, which stay.
//!
//! Answers are cached as `LlmAnswer {key, model, prompt, answer}` nodes keyed by the sha256 of
//! (model id, prompt id, input), written in the same transaction as the facts they made, so a
//! resumed or repeated pass never asks again.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::time::{Duration, Instant};

use graphstore::{Direction, GraphRead, Store, Value};
use llm_tools::prompts::{self, Prompt};
use llm_tools::{ChatModel, ChatRequest, Embedder, Message};
use sha2::{Digest, Sha256};

use crate::error::{Error, Result};
use crate::hierarchy::relations::{
    InstanceBox, RelationConfig, box_distance, candidate_pairs, spanning_tree,
};
use scene::GroundFrame;
use scene::records::InstanceRecord;

use scene::classes::SURFACE_CLASSES;

/// `RELATED.source` of the relations an LLM labelled.
pub const LLM_SOURCE: &str = "llm";

/// The cached answers of a map, by key.
#[derive(Debug, Default)]
pub struct LlmCache {
    answers: HashMap<String, serde_json::Value>,
}

impl LlmCache {
    /// Reads every `LlmAnswer` node.
    pub fn load(r: &impl GraphRead) -> Result<LlmCache> {
        let mut answers = HashMap::new();
        for id in r.nodes_with_label(scene::label::LLM_ANSWER)? {
            let key = r
                .node_prop(id, scene::key::KEY)?
                .and_then(|v| v.as_str().map(str::to_string));
            let ans = r
                .node_prop(id, scene::key::ANSWER)?
                .and_then(|v| v.as_str().map(str::to_string));
            if let (Some(k), Some(a)) = (key, ans)
                && let Ok(v) = serde_json::from_str(&a)
            {
                answers.insert(k, v);
            }
        }
        Ok(LlmCache { answers })
    }

    /// The key of one question: sha256 hex of model id, prompt id and input.
    pub fn key(model: &str, prompt: &Prompt, input: &str) -> String {
        let mut h = Sha256::new();
        for part in [model, &prompt.id(), input] {
            h.update((part.len() as u64).to_le_bytes());
            h.update(part.as_bytes());
        }
        h.finalize().iter().map(|b| format!("{b:02x}")).collect()
    }

    /// A cached answer.
    pub fn get(&self, key: &str) -> Option<&serde_json::Value> {
        self.answers.get(key)
    }

    /// Number of cached answers.
    pub fn len(&self) -> usize {
        self.answers.len()
    }

    /// Whether nothing is cached.
    pub fn is_empty(&self) -> bool {
        self.answers.is_empty()
    }
}

/// One answer to write: (key, answer) when it was not cached yet.
type NewAnswer = Option<(String, serde_json::Value)>;

/// Asks `model` (or the cache) one structured question.
fn ask(
    model: &mut dyn ChatModel,
    cache: &LlmCache,
    prompt: &Prompt,
    input: &str,
    schema: serde_json::Value,
    max_tokens: u32,
) -> Result<(serde_json::Value, NewAnswer)> {
    let key = LlmCache::key(&model.model_id(), prompt, input);
    if let Some(v) = cache.get(&key) {
        return Ok((v.clone(), None));
    }
    let req = ChatRequest::new(vec![Message::system(prompt.text), Message::user(input)])
        .with_schema(schema)
        .with_max_tokens(max_tokens);
    let r = model.chat(&req)?;
    let v = r
        .json
        .ok_or_else(|| Error::Invalid("the model gave no structured answer".into()))?;
    Ok((v.clone(), Some((key, v))))
}

fn write_answers(
    tx: &mut graphstore::WriteTxn<'_>,
    model: &str,
    prompt: &Prompt,
    answers: &[(String, serde_json::Value)],
) -> graphstore::Result<()> {
    for (k, v) in answers {
        tx.create_node_named(
            &[scene::label::LLM_ANSWER],
            &[
                (scene::key::KEY, Value::String(k.clone())),
                (scene::key::MODEL, Value::String(model.to_string())),
                (scene::key::PROMPT, Value::String(prompt.id())),
                (scene::key::ANSWER, Value::String(v.to_string())),
            ],
        )?;
    }
    Ok(())
}

/// A string property of a node (None when missing or not a string).
pub fn str_prop(r: &impl GraphRead, id: u64, key: &str) -> Result<Option<String>> {
    Ok(r.node_prop(id, key)?
        .and_then(|v| v.as_str().map(str::to_string)))
}

/// Whether an instance is an object (not a surface or a background tile); false for a node
/// that is no `Instance`.
///
/// # Errors
/// The store fails, or the instance lacks a required property.
pub fn is_object(r: &impl GraphRead, id: u64) -> Result<bool> {
    Ok(InstanceRecord::read(r, id)?.is_some_and(|i| is_object_record(&i)))
}

/// Whether an instance read through its record is an object: neither a surface class nor a
/// background tile (`tile` set).
pub fn is_object_record(inst: &InstanceRecord) -> bool {
    !SURFACE_CLASSES.contains(&inst.semantic_class.as_str()) && inst.tile.is_none()
}

/// Options of a pass.
#[derive(Debug, Clone, PartialEq)]
pub struct PassOptions {
    /// Stop starting new questions after this long (the pass is resumable).
    pub budget: Option<Duration>,
    /// Answers written per transaction.
    pub chunk: usize,
    /// Ask at most this many questions (the rest is left for a later run).
    pub max_items: Option<usize>,
}

impl Default for PassOptions {
    fn default() -> Self {
        PassOptions {
            budget: None,
            chunk: 16,
            max_items: None,
        }
    }
}

/// What a pass did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct PassReport {
    /// The model's id.
    pub model: String,
    /// The prompt's id (`task@vN`).
    pub prompt: String,
    /// Items the pass covers (instances with several captions, or candidate pairs).
    pub total: usize,
    /// Items already done before this run (same model and prompt).
    pub already_done: usize,
    /// Items done in this run.
    pub done: usize,
    /// Of those, answered from the cache without asking.
    pub cached: usize,
    /// Items still to do (budget or limit reached).
    pub left: usize,
    /// Mean milliseconds per question asked (cache hits excluded).
    pub ms_per_item: f64,
    /// Wall time of the run, seconds.
    pub secs: f64,
    /// For relations: labels written, by relation.
    pub labels: BTreeMap<String, usize>,
    /// Items whose answer broke the schema, with why (skipped; a later run asks again).
    pub rejected: Vec<String>,
}

/// The question for a caption merge: the latest `recent` captions, numbered, oldest first.
pub fn merge_input(captions: &[String], recent: usize) -> String {
    let tail = &captions[captions.len().saturating_sub(recent)..];
    let mut s = String::from("Captions of one object:\n");
    for (i, c) in tail.iter().enumerate() {
        s.push_str(&format!("{}. {}\n", i + 1, c.trim()));
    }
    s.push_str("Reply with the merged caption.");
    s
}

/// Merges each object's latest `recent` captions with `model` (see the module docs); the
/// instance feature becomes `normalize(0.5·embed(caption) + 0.5·detection_feature)` with
/// `embedder`, which must be the map's. Instances with one caption keep it.
pub fn merge_captions(
    store: &Store,
    model: &mut dyn ChatModel,
    embedder: &mut dyn Embedder,
    recent: usize,
    opts: &PassOptions,
) -> Result<PassReport> {
    let t0 = Instant::now();
    let prompt = prompts::MERGE_CAPTIONS;
    let model_id = model.model_id();
    let (todo, cache, already) = {
        let r = store.read()?;
        let mut todo = Vec::new();
        let mut already = 0;
        for id in r.nodes_with_label(scene::label::INSTANCE)? {
            let Some(inst) = InstanceRecord::read(&r, id)? else {
                continue;
            };
            if !is_object_record(&inst) {
                continue;
            }
            let captions: Vec<String> = inst.captions.unwrap_or_default();
            if captions.len() < 2 {
                continue;
            }
            if str_prop(&r, id, scene::key::CAPTION_PROMPT)?.as_deref()
                == Some(prompt.id().as_str())
                && str_prop(&r, id, scene::key::CAPTION_MODEL)?.as_deref()
                    == Some(model_id.as_str())
            {
                already += 1;
                continue;
            }
            let medoid = str_prop(&r, id, scene::key::CAPTION_MEDOID)?.unwrap_or(inst.caption);
            let df = inst.detection_feature.unwrap_or_default();
            todo.push((id, captions, medoid, df));
        }
        (todo, LlmCache::load(&r)?, already)
    };
    let mut report = PassReport {
        model: model_id.clone(),
        prompt: prompt.id(),
        total: todo.len() + already,
        already_done: already,
        ..PassReport::default()
    };
    run_pass(
        store,
        model,
        &prompt,
        &cache,
        opts,
        &todo,
        &mut report,
        t0,
        |(_, captions, _, _)| {
            (
                merge_input(captions, recent),
                prompts::merge_captions_schema(),
                64,
            )
        },
        |(id, _, medoid, df), v, _| {
            let caption = v["caption"].as_str().unwrap_or("").trim().to_string();
            let e = embedder.embed(&[caption.as_str()])?.remove(0);
            Ok((*id, caption, medoid.clone(), instance_feature(&e, df)))
        },
        |tx, writes| {
            let kc = tx.prop_key_id(scene::key::CAPTION)?;
            let km = tx.prop_key_id(scene::key::CAPTION_MEDOID)?;
            let kmod = tx.prop_key_id(scene::key::CAPTION_MODEL)?;
            let kp = tx.prop_key_id(scene::key::CAPTION_PROMPT)?;
            let kf = tx.prop_key_id(scene::key::FEATURE)?;
            for (id, caption, medoid, feature) in writes {
                tx.set_node_prop(*id, kc, Value::String(caption.clone()))?;
                tx.set_node_prop(*id, km, Value::String(medoid.clone()))?;
                tx.set_node_prop(*id, kmod, Value::String(model_id.clone()))?;
                tx.set_node_prop(*id, kp, Value::String(prompt.id()))?;
                tx.set_node_prop(*id, kf, Value::Vector(feature.clone()))?;
            }
            Ok(())
        },
    )?;
    Ok(report)
}

/// Runs `todo` through `model` (or the cache) with `prompt`: one question per item (`question` gives the
/// input, the schema and the token limit), `make` turns each answer into a write, and `commit`
/// writes a chunk of `opts.chunk` of them in one transaction with their new cache entries.
/// Stops starting items when the budget or the item limit is reached; fills in the report's
/// `done`, `cached`, `left`, `ms_per_item` and `secs`.
#[allow(clippy::too_many_arguments)]
fn run_pass<T, W>(
    store: &Store,
    model: &mut dyn ChatModel,
    prompt: &Prompt,
    cache: &LlmCache,
    opts: &PassOptions,
    todo: &[T],
    report: &mut PassReport,
    t0: Instant,
    question: impl Fn(&T) -> (String, serde_json::Value, u32),
    mut make: impl FnMut(&T, &serde_json::Value, &mut PassReport) -> Result<W>,
    commit: impl Fn(&mut graphstore::WriteTxn<'_>, &[W]) -> graphstore::Result<()>,
) -> Result<()> {
    let model_id = model.model_id();
    let (mut asked, mut asked_ms) = (0usize, 0.0);
    let mut i = 0;
    while i < todo.len() {
        let mut writes = Vec::new();
        let mut new_answers = Vec::new();
        while i < todo.len() && writes.len() < opts.chunk.max(1) {
            if opts.budget.is_some_and(|b| t0.elapsed() >= b)
                || opts.max_items.is_some_and(|m| report.done >= m)
            {
                break;
            }
            let (input, schema, max_tokens) = question(&todo[i]);
            let t = Instant::now();
            let (v, new) = match ask(model, cache, prompt, &input, schema, max_tokens) {
                Ok(x) => x,
                // an answer that breaks the schema (a grammar cannot bound numbers: 1.2 for a
                // confidence in [0, 1]) costs this item, not the pass
                Err(Error::Llm(llm_tools::Error::LlmAnswer(why))) => {
                    asked += 1;
                    asked_ms += t.elapsed().as_secs_f64() * 1e3;
                    report
                        .rejected
                        .push(format!("{}: {why}", input.lines().next().unwrap_or("")));
                    i += 1;
                    continue;
                }
                Err(e) => return Err(e),
            };
            match new {
                Some(a) => {
                    asked += 1;
                    asked_ms += t.elapsed().as_secs_f64() * 1e3;
                    new_answers.push(a);
                }
                None => report.cached += 1,
            }
            writes.push(make(&todo[i], &v, report)?);
            report.done += 1;
            i += 1;
        }
        if writes.is_empty() {
            break;
        }
        store.write(|tx| {
            commit(tx, &writes)?;
            write_answers(tx, &model_id, prompt, &new_answers)
        })?;
    }
    report.left = todo.len() - i + report.rejected.len();
    report.ms_per_item = if asked > 0 {
        asked_ms / asked as f64
    } else {
        0.0
    };
    report.secs = t0.elapsed().as_secs_f64();
    Ok(())
}

/// `normalize(0.5·e/|e| + 0.5·d/|d|)`, or `e` when `d` has another dimension.
pub fn instance_feature(e: &[f32], d: &[f32]) -> Vec<f32> {
    let n = |v: &[f32]| v.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-12);
    if d.len() != e.len() {
        let ne = n(e);
        return e.iter().map(|x| x / ne).collect();
    }
    let (ne, nd) = (n(e), n(d));
    let f: Vec<f32> = e
        .iter()
        .zip(d)
        .map(|(a, b)| 0.5 * a / ne + 0.5 * b / nd)
        .collect();
    let nf = n(&f);
    f.iter().map(|x| x / nf).collect()
}

fn ground_frame_of(r: &impl GraphRead) -> Result<GroundFrame> {
    scene::records::ground_frame(r).map_err(|e| Error::Invalid(e.to_string()))
}

/// The question for one pair: both captions, A's box centre relative to B's and both sizes
/// (ground x, ground y, up), and facts measured on the boxes: whether A lies within B (90 % of
/// its volume), whether A rests on top of B (its bottom within 0.3 m of B's top, footprints
/// overlapping), and the gap between them.
pub fn relation_input(
    frame: GroundFrame,
    a: (&str, &InstanceBox),
    b: (&str, &InstanceBox),
) -> String {
    let local = |p: [f64; 3]| {
        let g = frame.ground(p);
        [g[0], g[1], frame.height(p)]
    };
    let lo_hi = |x: &InstanceBox| {
        let (p, q) = (local(x.min), local(x.max));
        (
            [0, 1, 2].map(|i| p[i].min(q[i])),
            [0, 1, 2].map(|i| p[i].max(q[i])),
        )
    };
    let ((alo, ahi), (blo, bhi)) = (lo_hi(a.1), lo_hi(b.1));
    let centre = |lo: [f64; 3], hi: [f64; 3]| [0, 1, 2].map(|i| (lo[i] + hi[i]) / 2.0);
    let (ca, cb) = (centre(alo, ahi), centre(blo, bhi));
    let rel = [0, 1, 2].map(|i| ca[i] - cb[i]);
    let size = |lo: [f64; 3], hi: [f64; 3]| [0, 1, 2].map(|i| hi[i] - lo[i]);
    let overlap: f64 = (0..3)
        .map(|i| (ahi[i].min(bhi[i]) - alo[i].max(blo[i])).max(0.0))
        .product();
    let volume: f64 = (0..3).map(|i| (ahi[i] - alo[i]).max(1e-3)).product();
    let within = overlap / volume >= 0.9;
    let footprints_overlap = (0..2).all(|i| ahi[i] > blo[i] && bhi[i] > alo[i]);
    let on_top = footprints_overlap && (alo[2] - bhi[2]).abs() <= 0.3 && ca[2] > cb[2];
    let yes = |b: bool| if b { "yes" } else { "no" };
    let f = |v: [f64; 3]| format!("({:.1}, {:.1}, {:.1})", v[0], v[1], v[2]);
    format!(
        "Object A: {}\n  centre relative to B: {}, size: {}\nObject B: {}\n  size: {}\nMeasured: A lies within B: {}; A rests on top of B: {}; gap between the boxes: {:.1} m\nWhat is A relative to B?",
        a.0.trim(),
        f(rel),
        f(size(alo, ahi)),
        b.0.trim(),
        f(size(blo, bhi)),
        yes(within),
        yes(on_top),
        box_distance(a.1, b.1)
    )
}

/// Candidate pairs `(a, b)` of node ids, each object's caption and box by node id, and the
/// map's ground frame.
pub type RelationPairs = (
    Vec<(u64, u64)>,
    HashMap<u64, (String, InstanceBox)>,
    GroundFrame,
);

/// The candidate pairs of the relation pass, as node ids `(a, b)` with `a < b`: the spanning
/// tree over the objects' boxes plus every pair within `cfg.near_m`.
pub fn relation_pairs(r: &impl GraphRead, cfg: &RelationConfig) -> Result<RelationPairs> {
    let frame = ground_frame_of(r)?;
    let mut ids = Vec::new();
    let mut boxes = Vec::new();
    let mut info = HashMap::new();
    for id in r.nodes_with_label(scene::label::INSTANCE)? {
        let Some(inst) = InstanceRecord::read(r, id)? else {
            continue;
        };
        if !is_object_record(&inst) {
            continue;
        }
        let (min, max) = inst.bbox;
        let b = InstanceBox::new(frame, min, max, inst.obb);
        ids.push(id);
        boxes.push(b);
        info.insert(id, (inst.caption, b));
    }
    let mut pairs: BTreeSet<(u64, u64)> = BTreeSet::new();
    for (i, j, _) in spanning_tree(&boxes, frame, cfg) {
        pairs.insert((ids[i].min(ids[j]), ids[i].max(ids[j])));
    }
    for (i, j, _) in candidate_pairs(&boxes, frame, cfg.near_m) {
        pairs.insert((ids[i].min(ids[j]), ids[i].max(ids[j])));
    }
    Ok((pairs.into_iter().collect(), info, frame))
}

/// Labels the candidate pairs with `model` (see the module docs). Pairs that already have an
/// LLM `RELATED` edge from this model and prompt are skipped, so the pass resumes.
pub fn infer_relations(
    store: &Store,
    model: &mut dyn ChatModel,
    cfg: &RelationConfig,
    opts: &PassOptions,
) -> Result<PassReport> {
    let t0 = Instant::now();
    let prompt = prompts::RELATION;
    let model_id = model.model_id();
    let (todo, info, frame, cache, already) = {
        let r = store.read()?;
        let (pairs, info, frame) = relation_pairs(&r, cfg)?;
        let mut done: BTreeSet<(u64, u64)> = BTreeSet::new();
        if let Some(t) = r.rel_type(scene::rel::RELATED) {
            for &a in info.keys() {
                for adj in r.neighbours(a, Direction::Outgoing, Some(t))? {
                    if scene::records::RelationRecord::read(&r, adj.rel)?.source != LLM_SOURCE {
                        continue;
                    }
                    // who made it: keys beside the relation's record
                    let get = |k: &str| -> Result<Option<Value>> {
                        Ok(match r.prop_key(k) {
                            Some(k) => r.rel_prop(adj.rel, k)?,
                            None => None,
                        })
                    };
                    if get(scene::key::MODEL)? == Some(Value::String(model_id.clone()))
                        && get(scene::key::PROMPT)? == Some(Value::String(prompt.id()))
                    {
                        done.insert((a.min(adj.other), a.max(adj.other)));
                    }
                }
            }
        }
        let already = pairs.iter().filter(|p| done.contains(p)).count();
        let todo: Vec<(u64, u64)> = pairs.into_iter().filter(|p| !done.contains(p)).collect();
        (todo, info, frame, LlmCache::load(&r)?, already)
    };
    let mut report = PassReport {
        model: model_id.clone(),
        prompt: prompt.id(),
        total: todo.len() + already,
        already_done: already,
        ..PassReport::default()
    };
    run_pass(
        store,
        model,
        &prompt,
        &cache,
        opts,
        &todo,
        &mut report,
        t0,
        |(a, b)| {
            let (ia, ib) = (&info[a], &info[b]);
            (
                relation_input(frame, (&ia.0, &ia.1), (&ib.0, &ib.1)),
                prompts::relation_schema(),
                40,
            )
        },
        |(a, b), v, report| {
            let relation = v["relation"]
                .as_str()
                .unwrap_or("")
                .trim()
                .to_lowercase()
                .replace('_', " ");
            let confidence = v["relation_confidence"]
                .as_f64()
                .unwrap_or(0.0)
                .clamp(0.0, 1.0);
            *report.labels.entry(relation.clone()).or_default() += 1;
            Ok((
                *a,
                *b,
                relation,
                confidence,
                box_distance(&info[a].1, &info[b].1),
            ))
        },
        |tx, writes| {
            for (a, b, relation, confidence, d) in writes {
                // the relation, with the model and prompt that made it
                let mut props = scene::records::RelationRecord {
                    relation: relation.clone(),
                    distance_m: *d,
                    source: LLM_SOURCE.into(),
                    confidence: *confidence,
                }
                .props();
                props.push((scene::key::MODEL, Value::String(model_id.clone())));
                props.push((scene::key::PROMPT, Value::String(prompt.id())));
                tx.create_rel_named(*a, scene::rel::RELATED, *b, &props)?;
            }
            Ok(())
        },
    )?;
    Ok(report)
}
