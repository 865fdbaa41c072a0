//! Scores of the map's relation labels (LLM and geometric) against the relations that follow
//! from the simulator's ground-truth boxes (`ground_truth/objects.json`).

use std::path::Path;

use graphstore::GraphRead;
use ingest::sources::sim::truth::{TruthObject, footprint_gap, inside, match_truth, read_truth};
use scene::records::{InstanceRecord, RelationRecord};

use crate::Result;

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
    let Some(related) = r.rel_type(scene::rel::RELATED) else {
        return Ok(out);
    };
    // the model that labelled an LLM relation: a key beside the relation's record
    let model_of = |rel: u64| -> Result<Option<String>> {
        Ok(match r.prop_key(scene::key::MODEL) {
            Some(k) => r
                .rel_prop(rel, k)?
                .and_then(|v| v.as_str().map(str::to_string)),
            None => None,
        })
    };
    let mut matched: std::collections::HashMap<u64, Option<usize>> = Default::default();
    let mut match_of = |id: u64| -> Result<Option<usize>> {
        if let Some(m) = matched.get(&id) {
            return Ok(*m);
        }
        let m = InstanceRecord::read(r, id)?.and_then(|i| match_truth(&truth, i.centroid));
        matched.insert(id, m);
        Ok(m)
    };
    let mut models = std::collections::BTreeSet::new();
    let (mut llm_rows, mut geo_rows) = (Vec::new(), Vec::new());
    for a in r.nodes_with_label(scene::label::INSTANCE)? {
        let rels = r.neighbours(a, graphstore::Direction::Outgoing, Some(related))?;
        let mut geo: std::collections::HashMap<u64, Vec<String>> = Default::default();
        let mut llm: Vec<(u64, String)> = Vec::new();
        // outgoing: `adj.other` is the relation's end
        for adj in &rels {
            let rel = RelationRecord::read(r, adj.rel)?;
            match rel.source.as_str() {
                "llm" => {
                    if let Some(m) = model_of(adj.rel)? {
                        models.insert(m);
                    }
                    llm.push((adj.other, rel.relation));
                }
                "geometric" => geo.entry(adj.other).or_default().push(rel.relation),
                _ => {}
            }
        }
        // geometric labels of the reverse direction, turned round, count for the pair too
        // (incoming: `adj.other` is the relation's start)
        for adj in r.neighbours(a, graphstore::Direction::Incoming, Some(related))? {
            let rel = RelationRecord::read(r, adj.rel)?;
            if rel.source == "geometric" {
                let turned = match rel.relation.as_str() {
                    "on" => "under",
                    "under" => "on",
                    "inside" => "contains",
                    other => other,
                };
                geo.entry(adj.other).or_default().push(turned.to_string());
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
