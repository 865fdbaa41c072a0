//! Scores of the language-model passes against the simulator's ground truth
//! (`ground_truth/objects.json`: each object's box, true noun, colour and material).
//!
//! Captions: each object instance is matched to the ground-truth object whose box footprint
//! holds its centroid (0.5 m margin; the nearest centre wins). A caption gets an attribute
//! right when it names one of the true attribute's basic terms and no other (colours: red,
//! orange, yellow, green, blue, purple, pink, brown, black, white, grey, silver, beige;
//! materials: metal, steel, concrete, wood, aluminium, stone, glass, brick, plaster, plastic,
//! wire, iron), wrong when it names another (a contradiction), and missing when it names none.
//! The noun is right when the caption holds the true noun's head word. The map's `caption`
//! and, after an LLM merge, its `caption_medoid` are scored on the same instances.

use std::path::Path;

use graphstore::{GraphRead, Value};

use crate::error::{Error, Result};

/// Basic colour terms (a caption word counts when it starts with one: "yellowing", "red-brick").
pub const COLOURS: [&str; 14] = [
    "red", "orange", "yellow", "green", "blue", "purple", "pink", "brown", "black", "white",
    "grey", "gray", "silver", "beige",
];
/// Material terms.
pub const MATERIALS: [&str; 12] = [
    "metal",
    "steel",
    "concrete",
    "wood",
    "aluminium",
    "stone",
    "glass",
    "brick",
    "plaster",
    "plastic",
    "wire",
    "iron",
];

/// One ground-truth object of the simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthObject {
    /// Its id in `objects.json`.
    pub id: i64,
    /// Ground-plane centre (KITTI world x, z), metres.
    pub centre_xz: [f64; 2],
    /// Half the larger footprint side, metres.
    pub radius_m: f64,
    /// The simulator's class of the object (`objects.json` `class`: a SemanticKITTI class
    /// name or an open-vocabulary kind such as `bench`).
    pub class: String,
    /// True noun phrase.
    pub noun: String,
    /// True colour phrase (may be empty).
    pub colour: String,
    /// True material phrase (may be empty).
    pub material: String,
    /// Footprint corners on the ground plane (x, z), counter-clockwise or clockwise.
    pub footprint: [[f64; 2]; 4],
    /// Height range above the ground (bottom, top), metres.
    pub heights: (f64, f64),
}

/// Reads `DIR/ground_truth/objects.json`.
pub fn read_truth(sim_dir: &Path) -> Result<Vec<TruthObject>> {
    let path = sim_dir.join("ground_truth/objects.json");
    let v = crate::error::read_json(&path)?;
    let bad = |d: String| Error::File {
        path: path.clone(),
        detail: d,
    };
    let objs = v["objects"]
        .as_array()
        .ok_or_else(|| bad("no \"objects\" array".into()))?;
    let mut out = Vec::with_capacity(objs.len());
    for (i, o) in objs.iter().enumerate() {
        let num = |p: &str| {
            o.pointer(p)
                .and_then(serde_json::Value::as_f64)
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(format!("object {i}: {p} is not a finite number")))
        };
        let s = |p: &str| {
            o.pointer(p)
                .and_then(|x| x.as_str())
                .unwrap_or("")
                .to_string()
        };
        let (cx, cy, cz) = (
            num("/box/center/0")?,
            num("/box/center/1")?,
            num("/box/center/2")?,
        );
        let (w, h, l) = (
            num("/box/size/0")?,
            num("/box/size/1")?,
            num("/box/size/2")?,
        );
        let yaw = num("/box/yaw_rad").unwrap_or(0.0);
        // the length axis turns from +z towards +x by yaw; the width axis is perpendicular
        let (along, across) = ([yaw.sin(), yaw.cos()], [yaw.cos(), -yaw.sin()]);
        let corner = |a: f64, b: f64| {
            [
                cx + a * along[0] * l / 2.0 + b * across[0] * w / 2.0,
                cz + a * along[1] * l / 2.0 + b * across[1] * w / 2.0,
            ]
        };
        out.push(TruthObject {
            id: o["id"].as_i64().unwrap_or(i as i64),
            centre_xz: [cx, cz],
            radius_m: w.max(l) / 2.0,
            footprint: [
                corner(1.0, 1.0),
                corner(1.0, -1.0),
                corner(-1.0, -1.0),
                corner(-1.0, 1.0),
            ],
            // y points down with the ground at y = 0
            heights: (-(cy + h / 2.0), -(cy - h / 2.0)),
            class: s("/class"),
            noun: s("/attributes/noun"),
            colour: s("/attributes/colour"),
            material: s("/attributes/material"),
        });
    }
    Ok(out)
}

fn words(s: &str) -> Vec<String> {
    s.to_lowercase()
        .split(|c: char| !c.is_alphabetic())
        .filter(|w| !w.is_empty())
        .map(str::to_string)
        .collect()
}

/// The terms of `lexicon` that `text` names (a word names a term when it starts with it).
pub fn terms(text: &str, lexicon: &[&'static str]) -> Vec<&'static str> {
    let ws = words(text);
    lexicon
        .iter()
        .copied()
        .filter(|t| ws.iter().any(|w| w.starts_with(t)))
        .collect()
}

/// How a caption does on one attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Names a true term and no other.
    Right,
    /// Names a term the object does not have.
    Contradiction,
    /// Names none.
    Missing,
}

/// Judges `caption` on the attribute whose true phrase is `truth`; None when the truth names
/// no term of `lexicon`.
pub fn judge(caption: &str, truth: &str, lexicon: &[&'static str]) -> Option<Verdict> {
    let t = terms(truth, lexicon);
    if t.is_empty() {
        return None;
    }
    let c = terms(caption, lexicon);
    Some(if c.is_empty() {
        Verdict::Missing
    } else if c.iter().all(|x| t.contains(x)) {
        Verdict::Right
    } else {
        Verdict::Contradiction
    })
}

/// Shares over the judged instances of one attribute.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct AttributeScore {
    /// Instances whose object has the attribute.
    pub judged: usize,
    /// Share right.
    pub accuracy: f64,
    /// Share naming a wrong term.
    pub contradiction: f64,
    /// Share naming none.
    pub missing: f64,
}

/// Scores of one caption source.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct CaptionScores {
    /// Instances scored.
    pub instances: usize,
    /// Colour.
    pub colour: AttributeScore,
    /// Material.
    pub material: AttributeScore,
    /// Share whose caption holds the true noun's head word.
    pub noun_accuracy: f64,
    /// Mean caption length in words.
    pub mean_words: f64,
}

/// Scores `(caption, truth)` pairs.
pub fn score(pairs: &[(&str, &TruthObject)]) -> CaptionScores {
    let attr = |f: &dyn Fn(&TruthObject) -> &str, lex: &[&'static str]| {
        let v: Vec<Verdict> = pairs
            .iter()
            .filter_map(|(c, t)| judge(c, f(t), lex))
            .collect();
        let n = v.len().max(1) as f64;
        let share = |k: Verdict| v.iter().filter(|x| **x == k).count() as f64 / n;
        AttributeScore {
            judged: v.len(),
            accuracy: share(Verdict::Right),
            contradiction: share(Verdict::Contradiction),
            missing: share(Verdict::Missing),
        }
    };
    let n = pairs.len().max(1) as f64;
    CaptionScores {
        instances: pairs.len(),
        colour: attr(&|t| t.colour.as_str(), &COLOURS),
        material: attr(&|t| t.material.as_str(), &MATERIALS),
        noun_accuracy: pairs
            .iter()
            .filter(|(c, t)| {
                words(&t.noun)
                    .last()
                    .is_some_and(|h| words(c).iter().any(|w| w.starts_with(h.as_str())))
            })
            .count() as f64
            / n,
        mean_words: pairs
            .iter()
            .map(|(c, _)| words(c).len() as f64)
            .sum::<f64>()
            / n,
    }
}

/// The ground-truth object an instance centroid (KITTI world frame) belongs to: the nearest
/// centre among the objects whose footprint radius (plus 0.5 m) reaches it.
pub fn match_truth(truth: &[TruthObject], c: [f64; 3]) -> Option<usize> {
    truth
        .iter()
        .enumerate()
        .map(|(i, t)| (i, (t.centre_xz[0] - c[0]).hypot(t.centre_xz[1] - c[2]), t))
        .filter(|(_, d, t)| *d <= t.radius_m + 0.5)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _, _)| i)
}

/// Whether `p` lies inside the convex polygon `poly`.
fn inside(p: [f64; 2], poly: &[[f64; 2]; 4]) -> bool {
    // the point is inside when it is on the same side of every edge (or on an edge)
    let (mut left, mut right) = (false, false);
    for k in 0..4 {
        let (a, b) = (poly[k], poly[(k + 1) % 4]);
        let cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        left |= cross > 0.0;
        right |= cross < 0.0;
    }
    !(left && right)
}

/// Distance between two convex footprints (0 when they overlap).
pub fn footprint_gap(a: &[[f64; 2]; 4], b: &[[f64; 2]; 4]) -> f64 {
    if a.iter().any(|p| inside(*p, b)) || b.iter().any(|p| inside(*p, a)) {
        return 0.0;
    }
    let mut best = f64::INFINITY;
    for (p, poly) in a.iter().map(|p| (p, b)).chain(b.iter().map(|p| (p, a))) {
        for k in 0..4 {
            let (_, q) = planner::closest_on_segment(*p, poly[k], poly[(k + 1) % 4]);
            best = best.min((p[0] - q[0]).hypot(p[1] - q[1]));
        }
    }
    // crossing edges without a corner inside: treat as touching
    best
}

/// The relation of `a` to `b` that follows from the ground truth, when one does and they are
/// within 3 m: `inside` (a's centre within b's footprint and a's heights within b's), `on` (a
/// rests on b's top, footprints overlapping), `under` (the reverse), `next_to` (gap < 1 m),
/// `near` (gap < 3 m).
pub fn true_relation(a: &TruthObject, b: &TruthObject) -> Option<&'static str> {
    let gap = footprint_gap(&a.footprint, &b.footprint);
    if gap >= 3.0 {
        return None;
    }
    if gap == 0.0 {
        if inside(a.centre_xz, &b.footprint)
            && a.heights.0 >= b.heights.0 - 0.1
            && a.heights.1 <= b.heights.1 + 0.1
        {
            return Some("inside");
        }
        if (a.heights.0 - b.heights.1).abs() < 0.3 {
            return Some("on");
        }
        if (b.heights.0 - a.heights.1).abs() < 0.3 {
            return Some("under");
        }
    }
    Some(if gap < 1.0 { "next_to" } else { "near" })
}

/// A free-text relation in one of the five canonical words (None when it fits none). Phrases
/// are matched before single words ("in front of" is near, not inside; "leaning on" is next
/// to, not on).
pub fn canonical_relation(text: &str) -> Option<&'static str> {
    let t = format!(" {} ", text.to_lowercase().replace(['_', '-'], " "));
    let has = |w: &str| t.contains(&format!(" {w} "));
    const PHRASES: [(&str, &str); 9] = [
        ("in front of", "near"),
        ("across the road from", "near"),
        ("close to", "near"),
        ("next to", "next_to"),
        ("leaning on", "next_to"),
        ("leaning against", "next_to"),
        ("attached to", "next_to"),
        ("adjacent to", "next_to"),
        ("on top of", "on"),
    ];
    const WORDS: [(&str, &str); 18] = [
        ("inside", "inside"),
        ("in", "inside"),
        ("within", "inside"),
        ("on", "on"),
        ("atop", "on"),
        ("under", "under"),
        ("beneath", "under"),
        ("below", "under"),
        ("underneath", "under"),
        ("beside", "next_to"),
        ("by", "next_to"),
        ("against", "next_to"),
        ("touching", "next_to"),
        ("near", "near"),
        ("nearby", "near"),
        ("behind", "near"),
        ("left", "near"),
        ("right", "near"),
    ];
    PHRASES
        .iter()
        .chain(WORDS.iter())
        .find(|(w, _)| has(w))
        .map(|(_, c)| *c)
}

/// Whether a label agrees with the truth; `next_to` and `near` both mean "close by" and agree
/// with each other.
pub fn agrees(label: &str, truth: &str) -> bool {
    let close = |x: &str| x == "next_to" || x == "near";
    label == truth || (close(label) && close(truth))
}

/// Agreement of one source of labels with the ground truth.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RelationAgreement {
    /// Pairs with a true relation and a label from this source.
    pub pairs: usize,
    /// Share whose label agrees (next to and near agreeing with each other).
    pub agreement: f64,
    /// Share whose label is the true word itself (next to and near told apart).
    pub strict_agreement: f64,
    /// Per true relation: (pairs, share agreeing).
    pub per_truth: std::collections::BTreeMap<String, (usize, f64)>,
}

/// The report of `eval relations`.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RelationEval {
    /// LLM-labelled pairs in the map.
    pub llm_pairs: usize,
    /// Of those, with both ends matched to distinct ground-truth objects within 3 m.
    pub judged: usize,
    /// The models that labelled them.
    pub models: String,
    /// The LLM labels.
    pub llm: RelationAgreement,
    /// The geometric labels of the same pairs (agreeing when any of the pair's labels does).
    pub geometric: RelationAgreement,
}

fn agreement(rows: &[(&'static str, bool, bool)]) -> RelationAgreement {
    let mut per: std::collections::BTreeMap<String, (usize, usize)> = Default::default();
    for (t, ok, _) in rows {
        let e = per.entry((*t).to_string()).or_default();
        e.0 += 1;
        e.1 += usize::from(*ok);
    }
    RelationAgreement {
        pairs: rows.len(),
        agreement: rows.iter().filter(|r| r.1).count() as f64 / rows.len().max(1) as f64,
        strict_agreement: rows.iter().filter(|r| r.2).count() as f64 / rows.len().max(1) as f64,
        per_truth: per
            .into_iter()
            .map(|(k, (n, ok))| (k, (n, ok as f64 / n.max(1) as f64)))
            .collect(),
    }
}

/// Scores the map's LLM relations (and the geometric labels of the same pairs) against the
/// relations that follow from the simulator's ground truth in `sim_dir`.
pub fn eval_relations(r: &impl GraphRead, sim_dir: &Path) -> Result<RelationEval> {
    let truth = read_truth(sim_dir)?;
    let mut out = RelationEval::default();
    let Some(related) = r.rel_type("RELATED") else {
        return Ok(out);
    };
    let prop =
        |rel: &graphstore::Relationship, k: &str| r.prop_key(k).and_then(|k| rel.get(k).cloned());
    let mut matched: std::collections::HashMap<u64, Option<usize>> = Default::default();
    let mut match_of = |id: u64| -> Result<Option<usize>> {
        if let Some(m) = matched.get(&id) {
            return Ok(*m);
        }
        let m = match r.node_prop(id, "centroid")? {
            Some(Value::Point3D(c)) => match_truth(&truth, c),
            _ => None,
        };
        matched.insert(id, m);
        Ok(m)
    };
    let mut models = std::collections::BTreeSet::new();
    let (mut llm_rows, mut geo_rows) = (Vec::new(), Vec::new());
    for a in r.nodes_with_label("Instance")? {
        let rels = r.neighbours(a, graphstore::Direction::Outgoing, Some(related))?;
        let mut geo: std::collections::HashMap<u64, Vec<String>> = Default::default();
        let mut llm: Vec<(u64, String)> = Vec::new();
        for adj in &rels {
            let Some(rel) = r.rel(adj.rel)? else { continue };
            let label = prop(&rel, "relation")
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            match prop(&rel, "source")
                .and_then(|v| v.as_str().map(str::to_string))
                .as_deref()
            {
                Some("llm") => {
                    if let Some(m) =
                        prop(&rel, "model").and_then(|v| v.as_str().map(str::to_string))
                    {
                        models.insert(m);
                    }
                    llm.push((rel.end, label));
                }
                Some("geometric") => geo.entry(rel.end).or_default().push(label),
                _ => {}
            }
        }
        // geometric labels of the reverse direction, turned round, count for the pair too
        for adj in r.neighbours(a, graphstore::Direction::Incoming, Some(related))? {
            let Some(rel) = r.rel(adj.rel)? else { continue };
            if prop(&rel, "source")
                .and_then(|v| v.as_str().map(str::to_string))
                .as_deref()
                == Some("geometric")
            {
                let l = prop(&rel, "relation")
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_default();
                let turned = match l.as_str() {
                    "on" => "under",
                    "under" => "on",
                    "inside" => "contains",
                    other => other,
                };
                geo.entry(rel.start).or_default().push(turned.to_string());
            }
        }
        for (b, label) in llm {
            out.llm_pairs += 1;
            let (Some(ta), Some(tb)) = (match_of(a)?, match_of(b)?) else {
                continue;
            };
            if ta == tb {
                continue;
            }
            let Some(t) = true_relation(&truth[ta], &truth[tb]) else {
                continue;
            };
            out.judged += 1;
            let c = canonical_relation(&label);
            llm_rows.push((t, c.is_some_and(|c| agrees(c, t)), c == Some(t)));
            let g = geo.get(&b).map(Vec::as_slice).unwrap_or(&[]);
            let gc: Vec<&str> = g.iter().filter_map(|l| canonical_relation(l)).collect();
            geo_rows.push((t, gc.iter().any(|c| agrees(c, t)), gc.contains(&t)));
        }
    }
    out.models = models.into_iter().collect::<Vec<_>>().join(", ");
    out.llm = agreement(&llm_rows);
    out.geometric = agreement(&geo_rows);
    Ok(out)
}

/// The report of `eval captions`.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct CaptionEval {
    /// Object instances in the map.
    pub object_instances: usize,
    /// Of those, matched to a ground-truth object.
    pub matched: usize,
    /// Who wrote the map's captions (`medoid`, or the model id).
    pub caption_source: String,
    /// The map's `caption`, over every matched object.
    pub caption: CaptionScores,
    /// After an LLM merge: the merged instances only, their LLM caption and their medoid
    /// caption (`caption_medoid`) side by side on the same instances.
    pub merged: Option<MergedScores>,
}

/// LLM and medoid captions of the same merged instances.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct MergedScores {
    /// The LLM's captions.
    pub llm: CaptionScores,
    /// The medoid captions they replaced.
    pub medoid: CaptionScores,
}

/// Scores a map's object captions against the simulator's ground truth in `sim_dir`.
pub fn eval_captions(r: &impl GraphRead, sim_dir: &Path) -> Result<CaptionEval> {
    let truth = read_truth(sim_dir)?;
    let mut out = CaptionEval::default();
    let mut now: Vec<(String, usize)> = Vec::new();
    let mut merged: Vec<(String, String, usize)> = Vec::new();
    let mut sources = std::collections::BTreeSet::new();
    for id in r.nodes_with_label("Instance")? {
        let s = |k: &str| crate::llm::str_prop(r, id, k);
        if !crate::llm::is_object(r, id)? {
            continue;
        }
        out.object_instances += 1;
        let Some(Value::Point3D(c)) = r.node_prop(id, "centroid")? else {
            continue;
        };
        let Some(ti) = match_truth(&truth, c) else {
            continue;
        };
        out.matched += 1;
        let caption = s("caption")?.unwrap_or_default();
        let model = s("caption_model")?;
        if let (Some(m), Some(_)) = (s("caption_medoid")?, &model) {
            merged.push((caption.clone(), m, ti));
        }
        sources.insert(model.unwrap_or_else(|| "medoid".into()));
        now.push((caption, ti));
    }
    out.caption_source = sources.into_iter().collect::<Vec<_>>().join(", ");
    let pairs: Vec<(&str, &TruthObject)> =
        now.iter().map(|(c, i)| (c.as_str(), &truth[*i])).collect();
    out.caption = score(&pairs);
    if !merged.is_empty() {
        let llm: Vec<(&str, &TruthObject)> = merged
            .iter()
            .map(|(c, _, i)| (c.as_str(), &truth[*i]))
            .collect();
        let medoid: Vec<(&str, &TruthObject)> = merged
            .iter()
            .map(|(_, m, i)| (m.as_str(), &truth[*i]))
            .collect();
        out.merged = Some(MergedScores {
            llm: score(&llm),
            medoid: score(&medoid),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdicts() {
        assert_eq!(
            judge("a dark green hedge", "dark green", &COLOURS),
            Some(Verdict::Right)
        );
        assert_eq!(
            judge("a red hedge", "dark green", &COLOURS),
            Some(Verdict::Contradiction)
        );
        assert_eq!(
            judge("a green and red hedge", "green", &COLOURS),
            Some(Verdict::Contradiction)
        );
        assert_eq!(judge("a hedge", "green", &COLOURS), Some(Verdict::Missing));
        assert_eq!(
            judge("a yellowing tree", "yellowing", &COLOURS),
            Some(Verdict::Right)
        );
        assert_eq!(
            judge("a man in a white shirt", "in a white shirt", &COLOURS),
            Some(Verdict::Right)
        );
        assert_eq!(judge("a tree", "bright", &COLOURS), None);
        assert_eq!(
            judge("a wooden bench", "wooden", &MATERIALS),
            Some(Verdict::Right)
        );
        assert_eq!(
            judge("a stone bench", "wooden", &MATERIALS),
            Some(Verdict::Contradiction)
        );
    }

    fn square(c: [f64; 2], h: f64) -> [[f64; 2]; 4] {
        [
            [c[0] - h, c[1] - h],
            [c[0] + h, c[1] - h],
            [c[0] + h, c[1] + h],
            [c[0] - h, c[1] + h],
        ]
    }

    fn obj(c: [f64; 2], half: f64, heights: (f64, f64)) -> TruthObject {
        TruthObject {
            id: 0,
            centre_xz: c,
            radius_m: half,
            class: String::new(),
            noun: String::new(),
            colour: String::new(),
            material: String::new(),
            footprint: square(c, half),
            heights,
        }
    }

    #[test]
    fn true_relations_from_boxes() {
        let shelter = obj([0.0, 0.0], 2.0, (0.0, 2.5));
        let bench = obj([0.5, 0.0], 0.5, (0.0, 0.5));
        assert_eq!(true_relation(&bench, &shelter), Some("inside"));
        let table = obj([10.0, 0.0], 1.0, (0.0, 1.0));
        let lamp = obj([10.0, 0.0], 0.2, (1.0, 1.3));
        assert_eq!(true_relation(&lamp, &table), Some("on"));
        assert_eq!(true_relation(&table, &lamp), Some("under"));
        let post = obj([2.8, 0.0], 0.2, (0.0, 4.0));
        assert_eq!(true_relation(&post, &shelter), Some("next_to"));
        let far = obj([4.5, 0.0], 0.2, (0.0, 4.0));
        assert_eq!(true_relation(&far, &shelter), Some("near"));
        assert_eq!(
            true_relation(&obj([30.0, 0.0], 0.2, (0.0, 1.0)), &shelter),
            None
        );
        assert!(
            (footprint_gap(&square([0.0, 0.0], 1.0), &square([3.0, 0.0], 1.0)) - 1.0).abs() < 1e-9
        );
    }

    #[test]
    fn canonical_relations() {
        assert_eq!(canonical_relation("inside"), Some("inside"));
        assert_eq!(canonical_relation("in the bus shelter"), Some("inside"));
        assert_eq!(canonical_relation("leaning on"), Some("next_to"));
        assert_eq!(canonical_relation("on top of"), Some("on"));
        assert_eq!(canonical_relation("next_to"), Some("next_to"));
        assert_eq!(canonical_relation("across the road from"), Some("near"));
        assert_eq!(canonical_relation("in front of"), Some("near"));
        assert_eq!(canonical_relation("under"), Some("under"));
        assert_eq!(canonical_relation("unrelated"), None);
        assert!(agrees("near", "next_to") && !agrees("on", "inside"));
    }

    #[test]
    fn scores_are_shares() {
        let t = TruthObject {
            footprint: square([0.0, 0.0], 1.0),
            heights: (0.0, 1.0),
            id: 1,
            centre_xz: [0.0, 0.0],
            radius_m: 1.0,
            class: "bench".into(),
            noun: "park bench".into(),
            colour: "green".into(),
            material: "wooden".into(),
        };
        let s = score(&[("a green wooden bench", &t), ("a red bench", &t)]);
        assert_eq!(s.instances, 2);
        assert!((s.colour.accuracy - 0.5).abs() < 1e-12);
        assert!((s.colour.contradiction - 0.5).abs() < 1e-12);
        assert!((s.material.missing - 0.5).abs() < 1e-12);
        assert!((s.noun_accuracy - 1.0).abs() < 1e-12);
    }
}
