//! `opengraph ask`.

use super::args::*;
use super::common::*;

/// `opengraph ask`.
pub(crate) fn run(cmd: Command) -> anyhow::Result<()> {
    let Command::Ask {
        db,
        question,
        max_steps,
        llm,
        blind,
        json,
    } = cmd
    else {
        unreachable!("run dispatches only Command::Ask here")
    };
    // the service checks the request as it does for HTTP and MCP
    let req =
        api::ops::check_ask(&serde_json::json!({"question": question, "max_steps": max_steps}))?;
    // --llm none: the rule parser reads the question
    let mut model = llm_tools::chat::open(&llm.config(llm_tools::LlmConfig::default(), "local"))?;
    if let Some(m) = &model {
        errln!("language model: {}", m.model_id());
    }
    let a = if blind {
        let Some(m) = model.as_mut() else {
            return Err(
                UsageError("--blind needs a language model: --llm local or openai".into()).into(),
            );
        };
        api::ask::ask_blind(&mut **m, &req.question)?
    } else {
        let mut tb = open_toolbox(&db, false)?;
        api::ask::ask(
            model
                .as_mut()
                .map(|m| &mut **m as &mut dyn llm_tools::ChatModel),
            &mut tb,
            &req.question,
            req.max_steps as usize,
        )?
    };
    if json {
        outln!("{}", serde_json::to_string_pretty(&a)?);
    } else {
        for s in &a.steps {
            errln!(
                "tool {}({}){}",
                s.tool,
                s.arguments,
                if s.is_error {
                    format!(" -> error: {}", s.result)
                } else {
                    String::new()
                }
            );
        }
        match (&a.answer, &a.stopped) {
            (Some(t), _) => outln!("{t}"),
            (None, Some(why)) => errln!("no answer: {why}"),
            _ => {}
        }
    }
    Ok(())
}
