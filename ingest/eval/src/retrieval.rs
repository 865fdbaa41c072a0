//! Retrieval evaluation against the simulator's ground truth: R@1/2/3 per query type, where a
//! hit is a returned instance whose centroid lies on a right object (location-strict: the
//! instance is matched to the true object under it, [`ingest::sources::sim::truth::match_truth`], and
//! that object must satisfy the query's predicate).
//!
//! A query file is JSON Lines, one query per line:
//! `{"text": "the bench near the bus stop", "type": "relational", "target": ["bench"],
//!   "colour": "green", "near": {"class": ["bus stop shelter"], "within_m": 8}}`.
//! `type` is `named`, `relational` or `functional`; `target` lists the simulator classes
//! that answer it; `colour` (a word of the true colour), `material` and `near` (another
//! object of those classes within that footprint gap, metres) narrow it. A query whose
//! predicate no object satisfies is reported and not scored.

use std::collections::BTreeMap;
use std::path::Path;

use crate::{Error, Result};
use ingest::sources::sim::truth::{TruthObject, footprint_gap, match_truth, read_truth};

/// The anchor part of a predicate.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct NearPredicate {
    /// Simulator classes of the anchor.
    pub class: Vec<String>,
    /// Largest footprint gap to the anchor, metres.
    pub within_m: f64,
}

/// One query with its ground-truth predicate.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Query {
    /// The request text.
    pub text: String,
    /// `named`, `relational` or `functional`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Simulator classes that answer it.
    pub target: Vec<String>,
    /// A word the true colour must contain.
    #[serde(default)]
    pub colour: Option<String>,
    /// A word the true material must contain.
    #[serde(default)]
    pub material: Option<String>,
    /// An anchor the answer must stand near.
    #[serde(default)]
    pub near: Option<NearPredicate>,
}

/// The query types, in report order.
pub const QUERY_TYPES: [&str; 3] = ["named", "relational", "functional"];

/// Reads a query file (JSON Lines; blank lines and lines starting with `#` are skipped).
///
/// # Errors
/// The file cannot be read, a line is not a query (the message names the line), or a
/// `type` is not one of [`QUERY_TYPES`].
pub fn read_queries(path: &Path) -> Result<Vec<Query>> {
    let text = ingest::sources::sim::truth::read_text(path)?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let bad = |d: String| Error::File {
            path: path.to_path_buf(),
            detail: format!("line {}: {d}", i + 1),
        };
        let q: Query = serde_json::from_str(l).map_err(|e| bad(e.to_string()))?;
        if !QUERY_TYPES.contains(&q.kind.as_str()) {
            return Err(bad(format!(
                "\"type\" is {:?}; expected one of {QUERY_TYPES:?}",
                q.kind
            )));
        }
        if q.target.is_empty() || q.text.trim().is_empty() {
            return Err(bad("\"text\" and \"target\" must not be empty".into()));
        }
        if let Some(n) = &q.near
            && !(n.within_m.is_finite() && n.within_m >= 0.0)
        {
            return Err(bad("\"near.within_m\" must be a non-negative number".into()));
        }
        out.push(q);
    }
    if out.is_empty() {
        return Err(Error::File {
            path: path.to_path_buf(),
            detail: "no queries in the file".into(),
        });
    }
    Ok(out)
}

fn has_word(phrase: &str, word: &str) -> bool {
    phrase.to_lowercase().contains(&word.to_lowercase())
}

/// Indices of the true objects that satisfy `q`.
pub fn truth_set(q: &Query, truth: &[TruthObject]) -> Vec<usize> {
    truth
        .iter()
        .enumerate()
        .filter(|(_, t)| q.target.contains(&t.class))
        .filter(|(_, t)| q.colour.as_ref().is_none_or(|c| has_word(&t.colour, c)))
        .filter(|(_, t)| q.material.as_ref().is_none_or(|m| has_word(&t.material, m)))
        .filter(|(i, t)| {
            q.near.as_ref().is_none_or(|n| {
                truth.iter().enumerate().any(|(j, a)| {
                    j != *i
                        && n.class.contains(&a.class)
                        && footprint_gap(&t.footprint, &a.footprint) <= n.within_m
                })
            })
        })
        .map(|(i, _)| i)
        .collect()
}

/// Recall at 1, 2 and 3 of one query type.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct TypeScores {
    /// Queries scored.
    pub queries: usize,
    /// Share with a hit among the first 1, 2 and 3 results.
    pub r_at_1: f64,
    /// R@2.
    pub r_at_2: f64,
    /// R@3.
    pub r_at_3: f64,
}

/// The outcome of one query.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct QueryOutcome {
    /// The query text.
    pub text: String,
    /// Its type.
    #[serde(rename = "type")]
    pub kind: String,
    /// Rank (1-based) of the first hit among the first three, if any.
    pub first_hit: Option<usize>,
    /// True objects that satisfy the predicate.
    pub answers: usize,
    /// The first three results: (node id, caption, the true class under it, if any).
    pub returned: Vec<(u64, String, Option<String>)>,
}

/// The result of [`eval_retrieval`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RetrievalEval {
    /// Per query type.
    pub per_type: BTreeMap<String, TypeScores>,
    /// Every scored query.
    pub queries: Vec<QueryOutcome>,
    /// Queries that no true object satisfies (not scored).
    pub unanswerable: Vec<String>,
}

/// One returned instance: node id, caption and centroid (KITTI world frame, metres).
pub type Returned = (u64, String, [f64; 3]);

/// Runs every query through `find` (which returns its best results, best first) and scores
/// the first three against the simulator's objects in `SIM_DIR/ground_truth/objects.json`.
///
/// # Errors
/// The truth file cannot be read, or `find` fails.
pub fn eval_retrieval(
    sim_dir: &Path,
    queries: &[Query],
    mut find: impl FnMut(&str) -> Result<Vec<Returned>>,
) -> Result<RetrievalEval> {
    let truth = read_truth(sim_dir)?;
    let mut out = RetrievalEval::default();
    let mut hits: BTreeMap<String, [usize; 4]> = BTreeMap::new();
    for q in queries {
        let answers = truth_set(q, &truth);
        if answers.is_empty() {
            out.unanswerable.push(q.text.clone());
            continue;
        }
        let results = find(&q.text)?;
        let mut first_hit = None;
        let mut returned = Vec::new();
        for (rank, (id, caption, c)) in results.iter().take(3).enumerate() {
            let under = match_truth(&truth, *c);
            if first_hit.is_none() && under.is_some_and(|u| answers.contains(&u)) {
                first_hit = Some(rank + 1);
            }
            returned.push((*id, caption.clone(), under.map(|u| truth[u].class.clone())));
        }
        let h = hits.entry(q.kind.clone()).or_default();
        h[0] += 1;
        for (k, slot) in h[1..].iter_mut().enumerate() {
            if first_hit.is_some_and(|r| r <= k + 1) {
                *slot += 1;
            }
        }
        out.queries.push(QueryOutcome {
            text: q.text.clone(),
            kind: q.kind.clone(),
            first_hit,
            answers: answers.len(),
            returned,
        });
    }
    for (kind, h) in hits {
        let n = h[0].max(1) as f64;
        out.per_type.insert(
            kind,
            TypeScores {
                queries: h[0],
                r_at_1: h[1] as f64 / n,
                r_at_2: h[2] as f64 / n,
                r_at_3: h[3] as f64 / n,
            },
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obj(id: i64, class: &str, c: [f64; 2], colour: &str) -> TruthObject {
        let h = 0.5;
        TruthObject {
            id,
            centre_xz: c,
            radius_m: h,
            class: class.into(),
            noun: class.into(),
            colour: colour.into(),
            material: String::new(),
            footprint: [
                [c[0] - h, c[1] - h],
                [c[0] + h, c[1] - h],
                [c[0] + h, c[1] + h],
                [c[0] - h, c[1] + h],
            ],
            heights: (0.0, 1.0),
        }
    }

    #[test]
    fn predicates_select_the_right_objects() {
        let truth = vec![
            obj(1, "bench", [0.0, 0.0], "green"),
            obj(2, "bench", [50.0, 0.0], "brown"),
            obj(3, "bus stop shelter", [3.0, 0.0], "grey"),
        ];
        let q = |json: &str| -> Query { serde_json::from_str(json).unwrap() };
        let near = q(
            r#"{"text": "the bench near the bus stop", "type": "relational",
            "target": ["bench"], "near": {"class": ["bus stop shelter"], "within_m": 5}}"#,
        );
        assert_eq!(truth_set(&near, &truth), vec![0]);
        let brown = q(
            r#"{"text": "a brown bench", "type": "named", "target": ["bench"],
            "colour": "brown"}"#,
        );
        assert_eq!(truth_set(&brown, &truth), vec![1]);
        let none = q(
            r#"{"text": "a red bench", "type": "named", "target": ["bench"],
            "colour": "red"}"#,
        );
        assert!(truth_set(&none, &truth).is_empty());
    }

    #[test]
    fn bad_query_lines_name_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("q.jsonl");
        std::fs::write(
            &p,
            "# comment\n{\"text\": \"a bench\", \"type\": \"named\", \"target\": [\"bench\"]}\n{\"text\": \"x\", \"type\": \"odd\", \"target\": [\"bench\"]}\n",
        )
        .unwrap();
        let e = read_queries(&p).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("odd"), "{e}");
        std::fs::write(&p, "{\"text\": \"a bench\"").unwrap();
        let e = read_queries(&p).unwrap_err().to_string();
        assert!(e.contains("line 1"), "{e}");
    }
}
