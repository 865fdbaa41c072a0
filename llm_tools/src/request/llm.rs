//! The request parsed by a language model under the [`request_schema`] JSON Schema, grounded
//! in the text and completed from the rules.

use super::*;

/// Keeps only what a model's parse can point to in the request: attributes and anchor
/// phrases that occur in the text, a segment constraint only when the text has a road word
/// (crossroads, intersection, crossing, junction, bend, corner, straight), an ordinal only
/// with an ordinal word. Small models copy values from the prompt's examples; this drops them.
/// The target and the function objects are kept as given.
pub fn ground_in_text(mut r: Request, text: &str) -> Request {
    let t = normalise(text);
    let said = |p: &str| {
        let p = normalise(p);
        !p.is_empty() && t.contains(&p)
    };
    r.attributes.retain(|a| said(a));
    r.anchors.retain(|a| said(&a.phrase));
    if r.segment.is_some()
        && ![
            "crossroads",
            "intersection",
            "crossing",
            "junction",
            "bend",
            "corner",
            "straight",
        ]
        .iter()
        .any(|w| t.contains(w))
    {
        r.segment = None;
    }
    if r.ordinal.is_some()
        && ![
            "first", "second", "third", "fourth", "fifth", "nearest", "closest", "1st", "2nd",
            "3rd",
        ]
        .iter()
        .any(|w| t.split(' ').any(|x| x == *w))
    {
        r.ordinal = None;
        r.nearest = false;
    }
    r
}

/// The model's parse `r` with the fields it left empty taken from the rule parser's `rules`:
/// function objects, attributes, anchors, segment and ordinal.
pub fn fill_from(mut r: Request, rules: Request) -> Request {
    if r.objects.is_empty() {
        r.objects = rules.objects;
    }
    if r.attributes.is_empty() {
        r.attributes = rules.attributes;
    }
    if r.anchors.is_empty() {
        r.anchors = rules.anchors;
    }
    if r.segment.is_none() {
        r.segment = rules.segment;
    }
    if r.ordinal.is_none() {
        r.ordinal = rules.ordinal;
        r.nearest = rules.nearest;
    }
    if r.target.trim().is_empty() {
        r.target = rules.target;
    }
    r
}

/// Parses a request with a language model under [`request_schema`] (the answer is
/// validated against it), keeps what the text grounds ([`ground_in_text`]), fills what the
/// model left empty from the rule parser ([`fill_from`]), then checks it: a target is
/// required, distances are finite and non-negative.
///
/// # Errors
/// The model fails or answers something that is not a request.
pub fn parse_llm(model: &mut dyn ChatModel, text: &str) -> Result<Request> {
    if text.trim().is_empty() {
        return Err(Error::Invalid("the request text is empty".into()));
    }
    let req = ChatRequest::new(vec![
        Message::system(crate::prompts::PARSE_REQUEST.text),
        Message::user(text.trim()),
    ])
    .with_schema(request_schema())
    .with_max_tokens(300);
    let answer = model.chat(&req)?;
    let v = answer
        .json
        .ok_or_else(|| Error::LlmAnswer("no structured answer".into()))?;
    let r: Request =
        serde_json::from_value(v).map_err(|e| Error::LlmAnswer(format!("not a request: {e}")))?;
    let r = ground_in_text(r, text);
    // what the model left empty, the rule parser fills (when it can parse the text at all)
    let r = match parse_rules(text) {
        Ok(rules) => fill_from(r, rules),
        Err(_) => r,
    };
    if r.target.trim().is_empty() && r.objects.is_empty() {
        return Err(Error::LlmAnswer("the request names no target".into()));
    }
    if r.anchors
        .iter()
        .any(|a| a.distance_m.is_some_and(|d| !(d.is_finite() && d >= 0.0)))
    {
        return Err(Error::LlmAnswer(
            "an anchor distance is not a distance".into(),
        ));
    }
    Ok(r)
}
