//! `opengraph ask`: a question read as one task and answered from the tools' results.
//!
//! [`ask`] reads the question as one [`Task`] (count, nearest, distance, route length,
//! segment, colour, neighbours, locate, find): with a language model, the model fills the
//! task's flat form under a grammar (`ask_task@v2`, with worked examples), falling back to
//! the rule parser ([`parse_question`]) when its form is unusable; without one, the rule
//! parser alone. The task runs through the same [`Toolbox`] as MCP, and the answer is
//! composed from the tool's result, not generated; the transcript records the model, the
//! prompt, the tool calls and the times. Only a question no task fits goes to the free
//! agent loop ([`agent_loop`]), and only with a model.
//!
//! The agent loop: the model gets the
//! question and the tools (OpenAI-style function calling; grammar-constrained calls for local
//! models); each tool call runs through the same [`Toolbox`] as MCP and its JSON answer goes
//! back to the model, until it answers or the step limit is reached. The first round requires
//! a tool call (`tool_choice: required`): without it, small local models answer at once from
//! nothing (measured: Qwen2.5-Coder 1.5B answered "The bench near the bus stop" to "Where can I
//! post a letter near the bus stop?" without a call).

use std::time::Instant;

use llm_tools::chat::{ChatModel, ChatRequest, Message, Role, ToolSpec};
use llm_tools::request::SegmentConstraint;
use llm_tools::request::question::{
    Task, TaskForm, check_grounded, parse_question, task_form_schema,
};
use serde_json::{Value as Json, json};

use crate::tools::Toolbox;

/// A tool answer longer than this (characters) is cut for the model, with a note.
pub const MAX_TOOL_TEXT: usize = 3000;

/// One tool call of the agent.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AskStep {
    /// The tool.
    pub tool: String,
    /// Its arguments.
    pub arguments: Json,
    /// Its answer, or the error the model was shown.
    pub result: Json,
    /// Whether the call failed.
    pub is_error: bool,
}

/// The outcome of one question.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AskAnswer {
    /// The question.
    pub question: String,
    /// The model id and the prompt id.
    pub model: String,
    /// The tool calls, in order.
    pub steps: Vec<AskStep>,
    /// The model's final answer (None when the step limit stopped it).
    pub answer: Option<String>,
    /// Why it stopped without an answer.
    pub stopped: Option<String>,
    /// The whole conversation (the model's task form, or the agent loop's messages).
    pub transcript: Vec<Message>,
    /// The task the question was read as (None for the agent loop).
    pub task: Option<Task>,
    /// The answer's value, for checking: a count, a node id, metres, a colour, a segment
    /// (`{"id", "kind"}`), a list of node ids.
    pub value: Option<Json>,
    /// Milliseconds: reading the question, running the task.
    pub timings_ms: Option<[f64; 2]>,
}

/// The free agent loop: the model calls any tool until it answers, with at most `max_steps`
/// rounds of tool calls. [`ask`] runs it only as the last resort, for a question no task
/// form fits.
///
/// # Errors
/// The model fails (a tool failure is shown to the model, not returned).
pub fn agent_loop(
    model: &mut dyn ChatModel,
    toolbox: &mut Toolbox,
    question: &str,
    max_steps: usize,
) -> llm_tools::Result<AskAnswer> {
    if question.trim().is_empty() {
        return Err(llm_tools::Error::Invalid("the question is empty".into()));
    }
    let specs: Vec<ToolSpec> = toolbox
        .tools()
        .into_iter()
        .map(|t| ToolSpec {
            name: t.name.to_string(),
            description: t.description.to_string(),
            parameters: t.input_schema,
        })
        .collect();
    let mut messages = vec![
        Message::system(llm_tools::prompts::ASK.text),
        Message::user(question.trim()),
    ];
    let mut steps = Vec::new();
    let model_id = format!("{} ({})", model.model_id(), llm_tools::prompts::ASK.id());
    for step in 0..max_steps {
        let mut req = ChatRequest::new(messages.clone())
            .with_tools(specs.clone())
            .with_max_tokens(300);
        // the first round must look at the map: small models otherwise answer from nothing
        if step == 0 {
            req = req.with_required_tool();
        }
        let resp = model.chat(&req)?;
        if resp.tool_calls.is_empty() {
            messages.push(Message::new(Role::Assistant, resp.text.clone()));
            return Ok(AskAnswer {
                question: question.to_string(),
                model: model_id,
                steps,
                answer: Some(resp.text.trim().to_string()),
                stopped: None,
                transcript: messages,
                task: None,
                value: None,
                timings_ms: None,
            });
        }
        let mut assistant = Message::new(Role::Assistant, resp.text.clone());
        assistant.tool_calls = resp.tool_calls.clone();
        messages.push(assistant);
        for call in resp.tool_calls {
            let (result, is_error) = match toolbox.call(&call.name, &call.arguments) {
                Ok(v) => (v, false),
                Err(e) => (Json::String(e.to_string()), true),
            };
            let mut text = if is_error {
                format!("error: {}", result.as_str().unwrap_or_default())
            } else {
                serde_json::to_string(&result).unwrap_or_default()
            };
            if text.len() > MAX_TOOL_TEXT {
                let mut cut = MAX_TOOL_TEXT;
                while !text.is_char_boundary(cut) {
                    cut -= 1;
                }
                text.truncate(cut);
                text.push_str(" ... (cut)");
            }
            let mut m = Message::new(Role::Tool, text);
            m.tool_call_id = Some(call.id.clone());
            messages.push(m);
            steps.push(AskStep {
                tool: call.name,
                arguments: call.arguments,
                result,
                is_error,
            });
        }
    }
    Ok(AskAnswer {
        question: question.to_string(),
        model: model_id,
        steps,
        answer: None,
        stopped: Some(format!("the step limit ({max_steps}) was reached")),
        transcript: messages,
        task: None,
        value: None,
        timings_ms: None,
    })
}

/// The task a question is read as, with who read it and the messages.
fn read_question(
    model: Option<&mut dyn ChatModel>,
    question: &str,
) -> (Option<Task>, String, Vec<Message>) {
    // the rules' reading: the answer without a model, and with one what checks and fills its
    let by_rules = parse_question(question);
    let Some(model) = model else {
        return (by_rules, "rules".into(), Vec::new());
    };
    let id = format!(
        "{} ({})",
        model.model_id(),
        llm_tools::prompts::ASK_TASK.id()
    );
    let messages = vec![
        Message::system(llm_tools::prompts::ASK_TASK.text),
        Message::user(format!("Question: {}", question.trim())),
    ];
    let req = ChatRequest::new(messages.clone())
        .with_schema(task_form_schema())
        .with_max_tokens(160);
    let mut transcript = messages;
    let read = model.chat(&req).map_err(|e| e.to_string()).and_then(|a| {
        transcript.push(Message::new(Role::Assistant, a.text.clone()));
        let form: TaskForm = serde_json::from_value(a.json.ok_or("no structured answer")?)
            .map_err(|e| format!("not a task form: {e}"))?;
        form.into_task(question)
    });
    // a reading that is not the question's (a task without its cue, words the question does
    // not say) gives way to the rules' reading
    let read = read.and_then(|t| match check_grounded(&t, question) {
        Ok(()) => Ok(t),
        Err(why) if by_rules.is_some() => Err(format!("not grounded in the question: {why}")),
        Err(_) => Ok(t),
    });
    match read {
        Ok(t) => {
            let t = fill_from_rules(t, by_rules.clone());
            (Some(prefer_fuller(t, by_rules.as_ref())), id, transcript)
        }
        Err(why) => {
            transcript.push(Message::new(
                Role::Tool,
                format!("the model's task was unusable ({why}); the rule parser read it"),
            ));
            (by_rules, format!("rules, after {id}"), transcript)
        }
    }
}

/// Where the model and the rules read the same task, an argument the model gave as a piece
/// of the rules' argument for the same slot ("the curb" of "the hydrant by the curb") is
/// taken from the rules: the fuller description names the thing the question means, a
/// small model tends to keep the last noun of it. A distance or route whose two ends the
/// model made the same is the rules' reading too.
fn prefer_fuller(task: Task, rules: Option<&Task>) -> Task {
    let Some(rules) = rules else { return task };
    let (Ok(Json::Object(mut m)), Ok(Json::Object(r))) =
        (serde_json::to_value(&task), serde_json::to_value(rules))
    else {
        return task;
    };
    if m.get("task") != r.get("task") {
        return task;
    }
    let words = |v: &str| -> Vec<String> {
        v.to_lowercase()
            .split(|c: char| !c.is_alphanumeric() && c != '\'' && c != '-')
            .filter(|w| !w.is_empty() && !matches!(*w, "the" | "a" | "an"))
            .map(str::to_string)
            .collect()
    };
    let piece_of = |small: &[String], big: &[String]| {
        !small.is_empty() && small.len() < big.len() && big.windows(small.len()).any(|w| w == small)
    };
    if let (Some(Json::String(a)), Some(Json::String(b))) = (m.get("from"), m.get("to"))
        && (words(a) == words(b)
            || llm_tools::request::spec_in_words(a)
                .is_some_and(|x| llm_tools::request::spec_in_words(b) == Some(x)))
    {
        return rules.clone();
    }
    let mut changed = false;
    for (k, v) in m.iter_mut() {
        if let (Json::String(mine), Some(Json::String(theirs))) = (&*v, r.get(k))
            && piece_of(&words(mine), &words(theirs))
        {
            *v = Json::String(theirs.clone());
            changed = true;
        }
    }
    if !changed {
        return task;
    }
    serde_json::from_value(Json::Object(m)).unwrap_or(task)
}

/// What the model left empty in a task the rules read as the same task, the rules fill: a
/// count's segment, place or radius, a segment count's kind.
fn fill_from_rules(task: Task, rules: Option<Task>) -> Task {
    match (task, rules) {
        (
            Task::Count {
                kind,
                within,
                near,
                radius_m,
            },
            Some(Task::Count {
                within: w,
                near: n,
                radius_m: r,
                ..
            }),
        ) => {
            let (within, near, radius_m) = if within.is_none() && near.is_none() {
                (w, n, r)
            } else if near.is_none() && radius_m.is_none() && r.is_some() {
                // "within 20 m of X" read as a count in X
                (None, n.or(within), r)
            } else {
                (within, near, radius_m.or(r))
            };
            Task::Count {
                kind,
                within,
                near,
                radius_m,
            }
        }
        // the form holds one segment kind: a union said in the question comes from the rules,
        // as does a kind left empty or what the segments hold
        (
            Task::CountSegments {
                segment_kind,
                or_kinds,
                holding,
            },
            Some(Task::CountSegments {
                segment_kind: k,
                or_kinds: ors,
                holding: h,
            }),
        ) => {
            let (segment_kind, or_kinds) = if !ors.is_empty() || segment_kind.is_none() {
                (k, ors)
            } else {
                (segment_kind, or_kinds)
            };
            Task::CountSegments {
                segment_kind,
                or_kinds,
                holding: holding.or(h),
            }
        }
        // a count whose kind is road segments is a count of segments
        (Task::Count { kind, .. }, Some(t @ Task::CountSegments { .. }))
            if llm_tools::request::question::names_segments(&kind) =>
        {
            t
        }
        (t, _) => t,
    }
}

/// Answers `question`: read as one task (by the model when given, else or on failure by the
/// rules), run with the tools, the answer composed from their result. A question no task
/// fits goes to [`agent_loop`] with the model (`max_steps` rounds), or is answered "not
/// understood" without one.
///
/// # Errors
/// An empty question; the model fails in the agent loop. A task's tool failure is the
/// answer's `stopped`, not an error.
pub fn ask(
    model: Option<&mut dyn ChatModel>,
    toolbox: &mut Toolbox,
    question: &str,
    max_steps: usize,
) -> llm_tools::Result<AskAnswer> {
    if question.trim().is_empty() {
        return Err(llm_tools::Error::Invalid("the question is empty".into()));
    }
    let t0 = Instant::now();
    let mut model = model;
    let (task, parsed_by, transcript) = match model.as_mut() {
        Some(m) => read_question(Some(&mut **m), question),
        None => read_question(None, question),
    };
    let t_read = t0.elapsed().as_secs_f64() * 1e3;
    let Some(task) = task else {
        if let Some(m) = model {
            return agent_loop(m, toolbox, question, max_steps);
        }
        return Ok(AskAnswer {
            question: question.to_string(),
            model: parsed_by,
            steps: Vec::new(),
            answer: None,
            stopped: Some(
                "not understood without a language model: ask how many (objects of a kind, or T-junctions), the nearest X to a place, how far A is from B, how long the route from A to B is, which segment X is in, what colour X is, or what is next to X".into(),
            ),
            transcript,
            task: None,
            value: None,
            timings_ms: Some([t_read, 0.0]),
        });
    };
    let t1 = Instant::now();
    let mut steps = Vec::new();
    let mut task = task;
    let mut parsed_by = parsed_by;
    let mut done = run_task(toolbox, &task, &mut steps);
    // a model's task that cannot run: the rules' reading, when it is another
    if done.is_err()
        && parsed_by != "rules"
        && let Some(r) = parse_question(question).filter(|r| *r != task)
    {
        let again = run_task(toolbox, &r, &mut steps);
        if again.is_ok() {
            parsed_by = format!("rules, after {parsed_by}'s task failed");
            task = r;
            done = again;
        }
    }
    let t_run = t1.elapsed().as_secs_f64() * 1e3;
    let (answer, value, stopped) = match done {
        Ok((text, value)) => (Some(text), Some(value), None),
        Err(why) => (None, None, Some(why)),
    };
    Ok(AskAnswer {
        question: question.to_string(),
        model: parsed_by,
        steps,
        answer,
        stopped,
        transcript,
        task: Some(task),
        value,
        timings_ms: Some([t_read, t_run]),
    })
}

/// The blind baseline: `model` answers `question` without the map's tools (prompt
/// [`llm_tools::prompts::ASK_BLIND`]), a short answer and a value, so an evaluation can
/// measure what the tools add. No task, no steps; `timings_ms` is `[answering, 0]`.
///
/// # Errors
/// An empty question; the model fails or gives no structured answer.
pub fn ask_blind(model: &mut dyn ChatModel, question: &str) -> llm_tools::Result<AskAnswer> {
    if question.trim().is_empty() {
        return Err(llm_tools::Error::Invalid("the question is empty".into()));
    }
    let t0 = Instant::now();
    let prompt = &llm_tools::prompts::ASK_BLIND;
    let messages = vec![
        Message::system(prompt.text),
        Message::user(format!("Question: {}", question.trim())),
    ];
    let schema = json!({"type": "object",
        "properties": {"answer": {"type": "string", "maxLength": 200},
                       "value": {"type": ["number", "string"]}},
        "required": ["answer", "value"], "additionalProperties": false});
    let req = ChatRequest::new(messages.clone())
        .with_schema(schema)
        .with_max_tokens(96);
    let a = model.chat(&req)?;
    let mut transcript = messages;
    transcript.push(Message::new(Role::Assistant, a.text.clone()));
    let form = a.json.unwrap_or(Json::Null);
    // a whole number given as 3.0 is the count 3
    let value = form.get("value").cloned().map(|v| match v.as_f64() {
        Some(x) if x.fract() == 0.0 && x.abs() < 1e15 => json!(x as i64),
        _ => v,
    });
    Ok(AskAnswer {
        question: question.to_string(),
        model: format!("{} ({}), blind: no tools", model.model_id(), prompt.id()),
        steps: Vec::new(),
        answer: form
            .get("answer")
            .and_then(Json::as_str)
            .map(str::to_string),
        stopped: None,
        transcript,
        task: None,
        value,
        timings_ms: Some([t0.elapsed().as_secs_f64() * 1e3, 0.0]),
    })
}

/// Calls one tool and records the step; an error is the step's and the message returned.
fn call(
    toolbox: &mut Toolbox,
    steps: &mut Vec<AskStep>,
    tool: &str,
    arguments: Json,
) -> Result<Json, String> {
    let out = toolbox.call(tool, &arguments);
    let (result, is_error) = match &out {
        Ok(v) => (v.clone(), false),
        Err(e) => (Json::String(e.to_string()), true),
    };
    steps.push(AskStep {
        tool: tool.to_string(),
        arguments,
        result,
        is_error,
    });
    out.map_err(|e| format!("{tool}: {e}"))
}

/// The words for a segment kind.
fn segment_words(kind: &str) -> &str {
    match kind {
        "intersection" => "a crossroads",
        "t_intersection" => "a T-junction",
        "l_intersection" => "a bend",
        "straight_roadway" => "a straight road",
        other => other,
    }
}

/// The kind of the segment whose node id `text` gives ("segment 2337", "2337"), read with
/// `read_cypher`; `None` when the id is not a segment's.
fn segment_by_id(
    toolbox: &mut Toolbox,
    steps: &mut Vec<AskStep>,
    text: &str,
) -> Option<(String, Json)> {
    let spec = llm_tools::request::spec_in_words(text)?;
    let id: u64 = spec.rsplit_once(':')?.1.parse().ok()?;
    let a = call(
        toolbox,
        steps,
        "read_cypher",
        json!({"query": format!("MATCH (s:Segment) WHERE id(s) = {id} RETURN s.kind AS kind")}),
    )
    .ok()?;
    let kind = a["rows"].get(0)?["kind"].as_str()?.to_string();
    Some((
        format!("Segment {id} is {}.", segment_words(&kind)),
        json!({"id": id, "kind": kind}),
    ))
}

/// The object words name, as `find_objects` gives its results (`id`, `label`, `caption`,
/// `segment` as `[id, kind]`): by its node id when the words give one ("object #86",
/// "instance 12": `get_instance`), the best match in a segment when they give its id ("the
/// post box in segment 12"), else `find_objects`' best.
fn best_object(
    toolbox: &mut Toolbox,
    steps: &mut Vec<AskStep>,
    text: &str,
) -> Result<Json, String> {
    if let Some(spec) = llm_tools::request::spec_in_words(text)
        && let Some(id) = spec
            .strip_prefix("instance:")
            .or_else(|| spec.strip_prefix("node:"))
            .and_then(|n| n.parse::<u64>().ok())
    {
        let i = call(toolbox, steps, "get_instance", json!({ "id": id }))?;
        let p = &i["properties"];
        return Ok(json!({
            "id": id,
            "label": p["label"],
            "caption": p["caption"],
            "centroid": p["centroid"],
            "segment": [i["segment"]["id"], i["segment"]["kind"]],
        }));
    }
    if let Some((object, segment)) = llm_tools::request::object_in_segment(text) {
        let a = call(
            toolbox,
            steps,
            "find_objects",
            json!({"text": object, "k": 50}),
        )?;
        let there: Vec<&Json> = a["results"]
            .as_array()
            .map(|v| {
                v.iter()
                    .filter(|o| o["segment"][0].as_u64() == Some(segment))
                    .collect()
            })
            .unwrap_or_default();
        let labels: Vec<&str> = there
            .iter()
            .map(|o| o["label"].as_str().unwrap_or(""))
            .collect();
        let pick = llm_tools::kinds::first_of_kind(&object, &labels).unwrap_or(0);
        return there
            .get(pick)
            .map(|o| (*o).clone())
            .ok_or_else(|| format!("nothing in segment {segment} matches {object:?}"));
    }
    let a = call(
        toolbox,
        steps,
        "find_objects",
        json!({"text": text, "k": 1}),
    )?;
    a["results"]
        .get(0)
        .cloned()
        .ok_or_else(|| format!("nothing in the map matches {text:?}"))
}

/// Runs a task; returns the answer's text and value.
fn run_task(
    toolbox: &mut Toolbox,
    task: &Task,
    steps: &mut Vec<AskStep>,
) -> Result<(String, Json), String> {
    let f1 = |v: &Json| v.as_f64().unwrap_or(f64::NAN);
    match task {
        Task::Count {
            kind,
            within,
            near,
            radius_m,
        } => {
            let mut args = json!({"kind": kind, "list": 0});
            if let Some(w) = within {
                args["within"] = json!(w);
            }
            if let Some(n) = near {
                args["near"] = json!(n);
            }
            if let Some(r) = radius_m {
                args["radius_m"] = json!(r);
            }
            let a = call(toolbox, steps, "count_objects", args)?;
            let n = a["count"].as_u64().unwrap_or(0);
            let labels: Vec<String> = a["kind"]["labels"]
                .as_array()
                .map(|v| {
                    v.iter()
                        .map(|l| {
                            format!(
                                "{} {} ({})",
                                l["objects"],
                                l["label"].as_str().unwrap_or(""),
                                l["how"].as_str().unwrap_or("")
                            )
                        })
                        .collect()
                })
                .unwrap_or_default();
            let area = match a["area"]["by"].as_str() {
                Some("segment") => format!(" in segment {}", a["area"]["segment_id"]),
                Some("circle") => format!(
                    " within {} m of {}",
                    a["area"]["radius_m"],
                    near.as_deref().unwrap_or("the place")
                ),
                _ => " on the map".into(),
            };
            let how = if labels.is_empty() {
                String::from("no label of the map matches it")
            } else {
                format!("labels taken over the map: {}", labels.join(", "))
            };
            Ok((format!("{n} {kind}{area} ({how})."), json!(n)))
        }
        Task::CountSegments {
            segment_kind,
            or_kinds,
            holding,
        } => {
            let a = call(toolbox, steps, "describe_area", json!({}))?;
            let segs = a["segments"].as_array().cloned().unwrap_or_default();
            let kinds: Vec<SegmentConstraint> =
                segment_kind.iter().chain(or_kinds).copied().collect();
            let mut ids: Vec<u64> = segs
                .iter()
                .filter(|s| {
                    kinds.is_empty()
                        || kinds
                            .iter()
                            .any(|k| k.admits(s["kind"].as_str().unwrap_or("")))
                })
                .filter_map(|s| s["id"].as_u64())
                .collect();
            let name = |k: &SegmentConstraint| match k {
                SegmentConstraint::Crossroads => "crossroads",
                SegmentConstraint::TJunction => "T-junctions",
                SegmentConstraint::Bend => "bends",
                SegmentConstraint::StraightRoad => "straight roads",
                SegmentConstraint::Junction => "junctions",
            };
            let mut what = if kinds.is_empty() {
                "road segments".to_string()
            } else {
                kinds.iter().map(name).collect::<Vec<_>>().join(" or ")
            };
            if let Some(h) = holding {
                // every object of the kind, with its segment (IN_SEGMENT)
                let c = call(
                    toolbox,
                    steps,
                    "count_objects",
                    json!({"kind": h, "list": 500}),
                )?;
                let listed = c["objects"].as_array().map_or(0, |v| v.len() as u64);
                if c["count"].as_u64().unwrap_or(0) > listed {
                    return Err(format!(
                        "the map has more than {listed} objects of the kind {h:?}: too many to place in segments one by one"
                    ));
                }
                let holders: std::collections::BTreeSet<u64> = c["objects"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .filter_map(|o| o["segment"]["id"].as_u64())
                    .collect();
                ids.retain(|id| holders.contains(id));
                what = format!(
                    "{what} holding at least one {h} (an object is in the segment its IN_SEGMENT names; {} of the kind on the map)",
                    c["count"]
                );
            }
            Ok((
                format!(
                    "The map has {} {what} (segment node ids {:?}).",
                    ids.len(),
                    ids
                ),
                json!(ids.len()),
            ))
        }
        Task::Nearest { kind, near } => {
            let a = call(
                toolbox,
                steps,
                "nearest_objects",
                json!({"kind": kind, "near": near, "k": 1}),
            )?;
            let r = a["results"]
                .get(0)
                .ok_or_else(|| format!("the map has no {kind}"))?;
            Ok((
                format!(
                    "The nearest {} to {near} is instance {} (\"{}\"), {:.1} m away (ground-plane distance between centroids).",
                    r["label"].as_str().unwrap_or(kind),
                    r["id"],
                    r["caption"].as_str().unwrap_or(""),
                    f1(&r["distance_m"])
                ),
                r["id"].clone(),
            ))
        }
        Task::Distance { from, to } => {
            let a = call(
                toolbox,
                steps,
                "measure_distance",
                json!({"from": from, "to": to}),
            )?;
            let d = f1(&a["distance_m"]);
            Ok((
                format!(
                    "{from} and {to} are {d:.1} m apart (ground-plane distance between centroids)."
                ),
                json!(d),
            ))
        }
        Task::RouteLength { from, to } => {
            let a = call(
                toolbox,
                steps,
                "plan_route",
                json!({"from": from, "to": to}),
            )?;
            let d = f1(&a["route_length_m"]);
            Ok((
                format!("The route from {from} to {to} is {d:.1} m long along the lane graph."),
                json!(d),
            ))
        }
        Task::Segment { object } => {
            let o = match best_object(toolbox, steps, object) {
                Ok(o) => o,
                // the id of a segment itself ("what kind of segment is segment 2337"): its kind
                Err(e) if e.contains("is not an Instance") => {
                    return segment_by_id(toolbox, steps, object).ok_or(e);
                }
                Err(e) => return Err(e),
            };
            let seg = &o["segment"];
            let (id, kind) = (seg[0].clone(), seg[1].as_str().unwrap_or("").to_string());
            if id.is_null() {
                return Err(format!("instance {} is in no segment", o["id"]));
            }
            Ok((
                format!(
                    "Instance {} (\"{}\") is in segment {id}, {}.",
                    o["id"],
                    o["caption"].as_str().unwrap_or(""),
                    segment_words(&kind)
                ),
                json!({"id": id, "kind": kind}),
            ))
        }
        Task::Colour { object } => {
            let o = best_object(toolbox, steps, object)?;
            let i = call(toolbox, steps, "get_instance", json!({"id": o["id"]}))?;
            let colour = i["properties"]["colour"].as_str().map(str::to_string);
            match colour {
                Some(c) => Ok((
                    format!(
                        "Instance {} (\"{}\") is {c}.",
                        o["id"],
                        o["caption"].as_str().unwrap_or("")
                    ),
                    json!(c),
                )),
                None => Err(format!(
                    "instance {} (\"{}\") has no colour its captions agree on",
                    o["id"],
                    o["caption"].as_str().unwrap_or("")
                )),
            }
        }
        Task::Neighbours { object } => {
            let o = best_object(toolbox, steps, object)?;
            let a = call(toolbox, steps, "neighbours", json!({"id": o["id"], "k": 5}))?;
            let list: Vec<&Json> = a["neighbours"]
                .as_array()
                .map(|v| v.iter().collect())
                .unwrap_or_default();
            let words: Vec<String> = list
                .iter()
                .map(|n| {
                    format!(
                        "{} {} ({:.1} m)",
                        n["label"].as_str().unwrap_or(""),
                        n["id"],
                        f1(&n["gap_m"])
                    )
                })
                .collect();
            let ids: Vec<Json> = list.iter().map(|n| n["id"].clone()).collect();
            Ok((
                format!(
                    "Around instance {} (\"{}\"): {}.",
                    o["id"],
                    o["caption"].as_str().unwrap_or(""),
                    if words.is_empty() {
                        "nothing within 10 m".into()
                    } else {
                        words.join(", ")
                    }
                ),
                Json::Array(ids),
            ))
        }
        Task::Locate { text } => {
            let a = call(toolbox, steps, "locate", json!({"text": text, "k": 3}))?;
            let r = a["results"]
                .get(0)
                .ok_or("no road segment fits the description")?;
            Ok((
                format!(
                    "Most likely segment {}, {}.",
                    r["segment"],
                    segment_words(r["kind"].as_str().unwrap_or(""))
                ),
                r["segment"].clone(),
            ))
        }
        Task::Find { text } => {
            let o = best_object(toolbox, steps, text)?;
            let c = &o["centroid"];
            Ok((
                format!(
                    "Instance {} (\"{}\") at ({:.1}, {:.1}, {:.1}), segment {}.",
                    o["id"],
                    o["caption"].as_str().unwrap_or(""),
                    f1(&c[0]),
                    f1(&c[1]),
                    f1(&c[2]),
                    o["segment"][0]
                ),
                o["id"].clone(),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use llm_tools::chat::scripted::{Reply, Scripted};
    use serde_json::json;

    fn toolbox() -> (tempfile::TempDir, Toolbox) {
        let (dir, store) = crate::test_support::demo_store();
        (
            dir,
            Toolbox::new(store, crate::test_support::hash_finder(), false),
        )
    }

    /// The loop's protocol: a tool call's answer goes back to the model as a tool message
    /// with the call's id, a failing call is shown as an error, and the text answer ends it.
    #[test]
    fn tool_calls_feed_back_until_the_answer() {
        let (_dir, mut tb) = toolbox();
        let mut m = Scripted::new(
            "script",
            vec![
                Reply::Tools(vec![(
                    "read_cypher".into(),
                    json!({"query": "MATCH (n) RETURN count(n) AS n"}),
                )]),
                Reply::Tools(vec![("get_instance".into(), json!({"id": 999_999}))]),
                Reply::Text("There are nodes.".into()),
            ],
        );
        let a = agent_loop(&mut m, &mut tb, "How many nodes?", 5).unwrap();
        assert_eq!(a.answer.as_deref(), Some("There are nodes."));
        assert_eq!(a.steps.len(), 2);
        assert!(!a.steps[0].is_error && a.steps[0].result["row_count"] == 1);
        assert!(a.steps[1].is_error);
        let roles: Vec<Role> = a.transcript.iter().map(|m| m.role).collect();
        assert_eq!(
            roles,
            [
                Role::System,
                Role::User,
                Role::Assistant,
                Role::Tool,
                Role::Assistant,
                Role::Tool,
                Role::Assistant
            ]
        );
        assert_eq!(
            a.transcript[3].tool_call_id,
            Some(a.transcript[2].tool_calls[0].id.clone())
        );
        assert!(
            a.transcript[5].content.starts_with("error: no node 999999"),
            "{}",
            a.transcript[5].content
        );
        assert!(a.model.ends_with("(ask@v1)"));
    }

    fn demo_toolbox() -> (tempfile::TempDir, Toolbox) {
        let (dir, store) = crate::test_support::demo_store_with_features();
        let mut tb = Toolbox::new(store, crate::test_support::hash_finder(), true);
        tb.call(
            "write_cypher",
            &json!({"query": "MATCH (e:Environment) SET e.ground_frame = 'enu'"}),
        )
        .unwrap();
        (dir, tb)
    }

    /// The model's form is the task, its answer is composed from the tool's result (the
    /// value is count_objects' count), and what the model left out the rules fill; without a
    /// model the rules read the same question to the same value.
    #[test]
    fn a_question_is_one_task_answered_from_the_tools() {
        let (_dir, mut tb) = demo_toolbox();
        let truth = tb.call("count_objects", &json!({"kind": "bench"})).unwrap()["count"].clone();
        assert_eq!(truth, 1);
        let form = r#"{"action": "count", "kind": "benches", "place": "", "radius_m": null, "segment_kind": null, "to": ""}"#;
        let mut m = Scripted::new("script", vec![Reply::Text(form.into())]);
        let a = ask(Some(&mut m), &mut tb, "How many benches are there?", 3).unwrap();
        assert_eq!(a.value, Some(truth.clone()), "{a:?}");
        assert!(
            a.model
                .ends_with(&format!("({})", llm_tools::prompts::ASK_TASK.id()))
        );
        assert_eq!(a.steps.len(), 1);
        assert_eq!(a.steps[0].tool, "count_objects");
        assert!(a.answer.unwrap().starts_with("1 benches on the map"));
        let r = ask(None, &mut tb, "How many benches are there?", 3).unwrap();
        assert_eq!((r.value, r.model.as_str()), (Some(truth), "rules"));
        // a segment count the model left without its kind: the rules fill it
        let form = r#"{"action": "count_segments", "kind": "", "place": "", "radius_m": null, "segment_kind": null, "to": ""}"#;
        let mut m = Scripted::new("script", vec![Reply::Text(form.into())]);
        let a = ask(Some(&mut m), &mut tb, "How many T-junctions are there?", 3).unwrap();
        assert_eq!(
            a.task,
            Some(Task::count_segments(Some(SegmentConstraint::TJunction)))
        );
        // an unusable form: the rules read the question
        let mut m = Scripted::new("script", vec![Reply::Text("{}".into())]);
        let a = ask(Some(&mut m), &mut tb, "How many benches are there?", 3).unwrap();
        assert!(a.model.starts_with("rules, after script"), "{}", a.model);
        assert_eq!(a.value, Some(json!(1)));
    }

    /// A union of segment kinds and the segments holding a kind, each against Cypher's count
    /// on the same map; a model that reads the union as a count of objects gives way to the
    /// rules.
    #[test]
    fn unions_of_segment_kinds_and_segments_holding_a_kind_are_counted() {
        let (_dir, mut tb) = demo_toolbox();
        let cypher = |tb: &mut Toolbox, q: &str| {
            tb.call("read_cypher", &json!({"query": q})).unwrap()["rows"][0]["n"].clone()
        };
        let union = cypher(
            &mut tb,
            "MATCH (s:Segment) WHERE s.kind IN ['intersection', 't_intersection'] RETURN count(s) AS n",
        );
        let one = cypher(
            &mut tb,
            "MATCH (s:Segment) WHERE s.kind = 'intersection' RETURN count(s) AS n",
        );
        assert_ne!(union, one, "the demo map must tell a union from one kind");
        let a = ask(
            None,
            &mut tb,
            "How many crossroads or T-junctions are there?",
            3,
        )
        .unwrap();
        assert_eq!(a.value, Some(union.clone()), "{a:?}");
        let form = r#"{"action": "count", "kind": "crossroads or T-junctions", "place": "", "radius_m": null, "segment_kind": null, "to": ""}"#;
        let mut m = Scripted::new("script", vec![Reply::Text(form.into())]);
        let a = ask(
            Some(&mut m),
            &mut tb,
            "How many crossroads or T-junctions are there?",
            3,
        )
        .unwrap();
        assert_eq!(a.value, Some(union), "{a:?}");
        let holding = cypher(
            &mut tb,
            "MATCH (i:Instance)-[:IN_SEGMENT]->(s:Segment) WHERE i.label = 'bench' RETURN count(DISTINCT s) AS n",
        );
        let all = cypher(&mut tb, "MATCH (s:Segment) RETURN count(s) AS n");
        assert_ne!(holding, all);
        let a = ask(None, &mut tb, "How many segments have a bench?", 3).unwrap();
        assert_eq!(a.value, Some(holding), "{a:?}");
        assert_eq!(
            a.steps.iter().map(|s| s.tool.as_str()).collect::<Vec<_>>(),
            ["describe_area", "count_objects"]
        );
    }

    /// A model's argument that is a piece of the rules' argument for the same slot gives way
    /// to the rules' fuller one; a distance between one place and itself is the rules' task.
    /// The kind of a segment asked by the segment's own id is the segment's kind, as Cypher
    /// reads it; an instance's id still answers the instance's segment.
    #[test]
    fn a_segment_asked_by_its_id_answers_its_kind() {
        let (_dir, mut tb) = demo_toolbox();
        let row = tb
            .call(
                "read_cypher",
                &json!({"query": "MATCH (s:Segment) RETURN id(s) AS id, s.kind AS kind ORDER BY id LIMIT 1"}),
            )
            .unwrap()["rows"][0]
            .clone();
        let (id, kind) = (row["id"].as_u64().unwrap(), row["kind"].clone());
        let a = ask(
            None,
            &mut tb,
            &format!("What kind of segment is segment {id}?"),
            3,
        )
        .unwrap();
        assert_eq!(a.value, Some(json!({"id": id, "kind": kind})), "{a:?}");
        let inst = tb
            .call(
                "read_cypher",
                &json!({"query": "MATCH (i:Instance)-[:IN_SEGMENT]->(s) RETURN id(i) AS i, id(s) AS s LIMIT 1"}),
            )
            .unwrap()["rows"][0]
            .clone();
        let a = ask(
            None,
            &mut tb,
            &format!("Which segment is instance {} in?", inst["i"]),
            3,
        )
        .unwrap();
        assert_eq!(
            a.value.as_ref().map(|v| v["id"].clone()),
            Some(inst["s"].clone()),
            "{a:?}"
        );
    }

    #[test]
    fn the_fuller_description_wins_over_a_piece_of_it() {
        let colour = |o: &str| Task::Colour { object: o.into() };
        let rules = colour("the squat metal hydrant by the curb");
        assert_eq!(prefer_fuller(colour("the curb"), Some(&rules)), rules);
        // a different reading, or none, stays the model's
        assert_eq!(
            prefer_fuller(colour("the bench"), Some(&rules)),
            colour("the bench")
        );
        assert_eq!(prefer_fuller(colour("the curb"), None), colour("the curb"));
        let seg = Task::Segment {
            object: "the squat metal hydrant by the curb".into(),
        };
        assert_eq!(
            prefer_fuller(colour("the curb"), Some(&seg)),
            colour("the curb")
        );
        let d = |a: &str, b: &str| Task::Distance {
            from: a.into(),
            to: b.into(),
        };
        let rules = d("the centre of segment 12", "the silver hydrant");
        assert_eq!(
            prefer_fuller(d("segment:12", "the centre of segment 12"), Some(&rules)),
            rules
        );
        assert_eq!(
            prefer_fuller(
                d("the roadside", "the parking lane"),
                Some(&d(
                    "the white truck at the roadside",
                    "the hatchback in the parking lane"
                ))
            ),
            d(
                "the white truck at the roadside",
                "the hatchback in the parking lane"
            )
        );
    }

    #[test]
    fn the_step_limit_stops_a_model_that_never_answers() {
        let (_dir, mut tb) = toolbox();
        let mut m = Scripted::from_fn("loop", |_| {
            Reply::Tools(vec![("get_schema".into(), json!({}))])
        });
        let a = agent_loop(&mut m, &mut tb, "?", 3).unwrap();
        assert_eq!((a.steps.len(), a.answer.is_none()), (3, true));
        assert!(a.stopped.unwrap().contains("step limit"));
        assert!(agent_loop(&mut m, &mut tb, "  ", 3).is_err());
    }

    #[test]
    fn the_blind_baseline_answers_without_tools() {
        let mut m = Scripted::new(
            "script",
            vec![Reply::Text(
                r#"{"answer": "About 12.", "value": 12.0}"#.into(),
            )],
        );
        let a = ask_blind(&mut m, "How many benches are there?").unwrap();
        assert_eq!(a.value, Some(json!(12)));
        assert_eq!(a.answer.as_deref(), Some("About 12."));
        assert!(a.steps.is_empty() && a.task.is_none());
        assert!(
            a.model.contains("ask_blind@v1") && a.model.contains("no tools"),
            "{}",
            a.model
        );
        let mut m = Scripted::new("script", vec![Reply::Text(r#"{"answer": "x"}"#.into())]);
        assert!(
            ask_blind(&mut m, "How many?").is_err(),
            "no value: not the schema"
        );
        assert!(ask_blind(&mut m, "  ").is_err());
    }
}
