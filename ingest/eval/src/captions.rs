//! Scores of the map's captions against the simulator's ground truth
//! (`ground_truth/objects.json`: each object's box, true noun, colour and material).
//!
//! Each object instance is matched to the ground-truth object whose box footprint
//! holds its centroid (0.5 m margin; the nearest centre wins). A caption gets an attribute
//! right when it names one of the true attribute's basic terms and no other (colours: red,
//! orange, yellow, green, blue, purple, pink, brown, black, white, grey, silver, beige;
//! materials: metal, steel, concrete, wood, aluminium, stone, glass, brick, plaster, plastic,
//! wire, iron), wrong when it names another (a contradiction), and missing when it names none.
//! The noun is right when the caption holds the true noun's head word. The map's `caption`
//! and, after an LLM merge, its `caption_medoid` are scored on the same instances.

use std::path::Path;

use graphstore::GraphRead;
use ingest::sources::sim::truth::{TruthObject, match_truth, read_truth};

use crate::Result;

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
    for id in r.nodes_with_label(scene::label::INSTANCE)? {
        let s = |k: &str| ingest::llm::str_prop(r, id, k);
        let Some(inst) = scene::records::InstanceRecord::read(r, id)? else {
            continue;
        };
        if !ingest::llm::is_object_record(&inst) {
            continue;
        }
        out.object_instances += 1;
        let Some(ti) = match_truth(&truth, inst.centroid) else {
            continue;
        };
        out.matched += 1;
        let caption = inst.caption;
        let model = s(scene::key::CAPTION_MODEL)?;
        if let (Some(m), Some(_)) = (s(scene::key::CAPTION_MEDOID)?, &model) {
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

    #[test]
    fn scores_are_shares() {
        let t = TruthObject {
            footprint: [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]],
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
