//! The map-wide labelling pass: every object's open-vocabulary label, normalised across the
//! map so that one kind of object has one label, and the colour and material its captions
//! agree on (rules in [`llm_tools::labels`]). It runs after the objects are finished, in
//! one transaction, and writes only what changed.

use super::*;
use llm_tools::labels::{self, Lexicon};

/// What the labelling pass did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct LabelReport {
    /// Objects labelled (ground surfaces are not).
    pub objects: usize,
    /// Distinct noun phrases the captions used.
    pub phrases: usize,
    /// Distinct labels after normalisation.
    pub labels: usize,
    /// Objects whose label, colour or material was written.
    pub written: usize,
    /// Why the WordNet lexicon was not used, when it was not (synonyms are then not joined).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lexicon_missing: Option<String>,
}

/// The lexicon for labels: WordNet from the models directory, or an empty one with the
/// reason.
pub(super) fn lexicon() -> (Lexicon, Option<String>) {
    match Lexicon::load_default() {
        Ok(l) => (l, None),
        Err(e) => (Lexicon::default(), Some(e)),
    }
}

/// The map-wide label of each noun phrase ([`labels::normalise`]), given one phrase per
/// object; every phrase is a key of the answer.
///
/// # Errors
/// The embedder fails.
pub(super) fn labels_of<'p>(
    phrases: impl IntoIterator<Item = &'p str>,
    lexicon: &Lexicon,
    emb: &mut EmbedCache<'_>,
) -> Result<BTreeMap<String, String>> {
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for p in phrases {
        *counts.entry(p.to_string()).or_insert(0) += 1;
    }
    labels::normalise(&counts, lexicon, &mut |texts| {
        emb.get_all(texts)
            .map_err(|e| llm_tools::Error::Invalid(e.to_string()))
    })
    .map_err(|e| Error::Invalid(format!("normalising labels: {e}")))
}

/// Labels every object `Instance` of `store` (see the module documentation).
pub(super) fn label_instances(
    store: &Store,
    emb: &mut EmbedCache<'_>,
    lexicon: &Lexicon,
) -> Result<LabelReport> {
    let r = store.read()?;
    // (node, phrase, colour, material, stored label, colour, material)
    type Row = (
        u64,
        String,
        Option<String>,
        Option<String>,
        [Option<String>; 3],
    );
    let mut rows: Vec<Row> = Vec::new();
    for id in r.nodes_with_label(scene::label::INSTANCE)? {
        let Some(rec) = InstanceRecord::read(&r, id)? else {
            continue;
        };
        if rec.tile.is_some() || classes::SURFACE_CLASSES.contains(&rec.semantic_class.as_str()) {
            continue;
        }
        let captions = rec
            .captions
            .clone()
            .filter(|c| !c.is_empty())
            .unwrap_or_else(|| vec![rec.caption.clone()]);
        let Some(phrase) = labels::object_phrase(&captions, lexicon) else {
            continue;
        };
        rows.push((
            id,
            phrase,
            labels::agreed_colour(&captions),
            labels::agreed_material(&captions),
            [rec.label, rec.colour, rec.material],
        ));
    }
    drop(r);
    let map = labels_of(rows.iter().map(|row| row.1.as_str()), lexicon, emb)?;
    let mut report = LabelReport {
        objects: rows.len(),
        // every phrase is a key of the map
        phrases: map.len(),
        labels: map
            .values()
            .collect::<std::collections::BTreeSet<_>>()
            .len(),
        ..LabelReport::default()
    };
    let changes: Vec<(u64, [Option<String>; 3])> = rows
        .into_iter()
        .filter_map(|(id, phrase, colour, material, stored)| {
            let want = [map.get(&phrase).cloned(), colour, material];
            (want != stored).then_some((id, want))
        })
        .collect();
    report.written = changes.len();
    if !changes.is_empty() {
        store.write(|tx| {
            let keys = [key::LABEL, key::COLOUR, key::MATERIAL];
            for (id, want) in &changes {
                for (k, v) in keys.iter().zip(want) {
                    let k = tx.prop_key_id(k)?;
                    match v {
                        Some(v) => tx.set_node_prop(*id, k, Value::String(v.clone()))?,
                        None => {
                            tx.remove_node_prop(*id, k)?;
                        }
                    }
                }
            }
            Ok(())
        })?;
    }
    Ok(report)
}
