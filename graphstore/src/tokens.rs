//! Interned names: labels, relationship types and property keys map to dense `u32` ids, so
//! hot paths compare integers, not strings.

use std::collections::HashMap;

/// A node label, interned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct LabelId(pub u32);

/// A relationship type, interned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RelType(pub u32);

/// A property key, interned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PropKey(pub u32);

/// The three name spaces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum TokenKind {
    Label,
    RelType,
    PropKey,
}

impl TokenKind {
    fn prefix(self) -> &'static str {
        match self {
            TokenKind::Label => "L:",
            TokenKind::RelType => "T:",
            TokenKind::PropKey => "P:",
        }
    }

    pub(crate) fn noun(self) -> &'static str {
        match self {
            TokenKind::Label => "label",
            TokenKind::RelType => "relationship type",
            TokenKind::PropKey => "property key",
        }
    }

    pub(crate) fn qualify(self, name: &str) -> String {
        format!("{}{name}", self.prefix())
    }

    /// The kind of a qualified name ("L:Instance").
    fn of_qualified(q: &str) -> Option<TokenKind> {
        [TokenKind::Label, TokenKind::RelType, TokenKind::PropKey]
            .into_iter()
            .find(|k| q.starts_with(k.prefix()))
    }

    fn slot(self) -> usize {
        self as usize
    }
}

/// Committed tokens (append-only).
#[derive(Debug, Clone, Default)]
pub(crate) struct Tokens {
    /// Qualified names ("L:Instance") by id.
    names: Vec<String>,
    /// Ids by plain name, one map per kind (a lookup allocates nothing).
    by_name: [HashMap<String, u32>; 3],
}

impl Tokens {
    pub(crate) fn push(&mut self, qualified: String) -> u32 {
        let id = self.names.len() as u32;
        if let Some(k) = TokenKind::of_qualified(&qualified) {
            self.by_name[k.slot()].insert(qualified[2..].to_string(), id);
        }
        self.names.push(qualified);
        id
    }

    pub(crate) fn len(&self) -> u32 {
        self.names.len() as u32
    }

    pub(crate) fn get(&self, kind: TokenKind, name: &str) -> Option<u32> {
        self.by_name[kind.slot()].get(name).copied()
    }

    pub(crate) fn name(&self, id: u32) -> Option<&str> {
        self.names.get(id as usize).map(|q| &q[2..])
    }

    /// All `(id, name)` of one kind, sorted by name.
    pub(crate) fn all(&self, kind: TokenKind) -> Vec<(u32, String)> {
        let p = kind.prefix();
        let mut v: Vec<(u32, String)> = self
            .names
            .iter()
            .enumerate()
            .filter(|(_, q)| q.starts_with(p))
            .map(|(i, q)| (i as u32, q[2..].to_string()))
            .collect();
        v.sort_by(|a, b| a.1.cmp(&b.1));
        v
    }
}
