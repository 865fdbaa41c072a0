//! The two ends of a route in words: "from A to B", "to B".

use super::*;

/// The two ends of a navigation request, as words.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct RouteWords {
    /// Where to start (None when the request does not say).
    pub from: Option<String>,
    /// Where to go.
    pub to: String,
}

/// Words before a relation's "to" that keep it from ending the start ("next to the bus stop").
pub(super) const TO_TAKERS: [&str; 7] =
    ["next", "close", "adjacent", "near", "opposite", "up", "due"];

/// Splits a navigation request into its start and goal: "from A to B", "to B from A",
/// "take me to B", "how do I get from A to B". A "to" that belongs to a relation ("next to",
/// "close to") does not split.
///
/// # Errors
/// No goal can be found in the text.
pub fn parse_route(text: &str) -> Result<RouteWords> {
    let mut t = normalise(text);
    loop {
        let before = t.len();
        for l in [
            "please ",
            "can you ",
            "could you ",
            "take me ",
            "bring me ",
            "get me ",
            "guide me ",
            "navigate ",
            "drive ",
            "go ",
            "how do i get ",
            "how can i get ",
            "i want to go ",
            "i need to go ",
            "i'd like to go ",
            "route ",
            "plan a route ",
            "a route ",
            "find a way ",
            "the way ",
        ] {
            if let Some(rest) = t.strip_prefix(l) {
                t = rest.to_string();
            }
        }
        if t.len() == before {
            break;
        }
    }
    // the " to " that splits: not one that a relation word takes
    let split_to = |s: &str| -> Option<usize> {
        let mut from = 0;
        while let Some(i) = find_words(&s[from..], "to").map(|i| i + from) {
            let prev = s[..i].split_whitespace().last().unwrap_or("");
            if !TO_TAKERS.contains(&prev) {
                return Some(i);
            }
            from = i + 2;
        }
        None
    };
    let clean = |s: &str| -> Option<String> {
        let s = s.trim();
        (!strip_articles(s).is_empty()).then(|| s.to_string())
    };
    let bad = || {
        Error::Invalid(format!(
            "no destination in {text:?}: say where to go (\"to ...\")"
        ))
    };
    if let Some(rest) = t.strip_prefix("from ") {
        let i = split_to(rest).ok_or_else(bad)?;
        let to = clean(&rest[i + 2..]).ok_or_else(bad)?;
        return Ok(RouteWords {
            from: clean(&rest[..i]),
            to,
        });
    }
    let rest = t.strip_prefix("to ").unwrap_or(&t);
    // "B from A"
    if let Some(i) = find_words(rest, "from") {
        let to = clean(&rest[..i]).ok_or_else(bad)?;
        return Ok(RouteWords {
            from: clean(&rest[i + 4..]),
            to,
        });
    }
    Ok(RouteWords {
        from: None,
        to: clean(rest).ok_or_else(bad)?,
    })
}
