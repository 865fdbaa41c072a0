//! The docs agree with the binary: every relative link in README.md and docs/*.md names a
//! file that exists, and every flag the README's CLI block shows is one its command takes
//! (per `opengraph CMD --help`).

mod common;
use common::og;

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn markdown_files() -> Vec<PathBuf> {
    let mut out = vec![root().join("README.md"), root().join("ARCHITECTURE.md")];
    for d in [
        "docs",
        "graphstore",
        "planner",
        "llm_tools",
        "ingest",
        "api",
    ] {
        let Ok(rd) = std::fs::read_dir(root().join(d)) else {
            continue;
        };
        for e in rd.flatten() {
            if e.path().extension().is_some_and(|x| x == "md") {
                out.push(e.path());
            }
        }
    }
    out.retain(|p| p.exists());
    out.sort();
    out
}

#[test]
fn every_relative_link_names_a_file() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for md in markdown_files() {
        let text = std::fs::read_to_string(&md).unwrap();
        for (i, line) in text.lines().enumerate() {
            let mut rest = line;
            while let Some(k) = rest.find("](") {
                let tail = &rest[k + 2..];
                let Some(end) = tail.find(')') else { break };
                let target = &tail[..end];
                rest = &tail[end..];
                if target.starts_with("http")
                    || target.starts_with('#')
                    || target.starts_with("mailto:")
                {
                    continue;
                }
                let file = target.split('#').next().unwrap_or_default();
                if file.is_empty() {
                    continue;
                }
                checked += 1;
                let path = md.parent().unwrap().join(file);
                if !path.exists() {
                    broken.push(format!("{}:{}: {target}", md.display(), i + 1));
                }
            }
        }
    }
    assert!(checked > 10, "only {checked} links found");
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn every_flag_in_the_readme_cli_block_exists() {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let start = text.find("## The CLI").expect("a CLI section");
    let block_start = start + text[start..].find("```sh").unwrap() + 5;
    let block_end = block_start + text[block_start..].find("```").unwrap();
    // commands with their lines (continuation lines are indented)
    let mut commands: Vec<(Vec<String>, String)> = Vec::new();
    for line in text[block_start..block_end].lines() {
        if let Some(rest) = line.strip_prefix("opengraph ") {
            let words: Vec<&str> = rest.split_whitespace().collect();
            let mut cmd = vec![words[0].to_string()];
            // a subcommand: `eval semseg`
            if let Some(w) = words.get(1)
                && !w.starts_with('-')
                && !w.starts_with('"')
                && !w.starts_with('[')
                && !w.starts_with('(')
                && !w.starts_with('#')
                && w.chars().all(|c| c.is_ascii_lowercase())
            {
                cmd.push((*w).to_string());
            }
            commands.push((cmd, rest.to_string()));
        } else if let Some(last) = commands.last_mut() {
            last.1.push(' ');
            last.1.push_str(line);
        }
    }
    assert!(commands.len() > 20, "{} commands", commands.len());
    let mut missing = Vec::new();
    for (cmd, line) in &commands {
        let mut args: Vec<&str> = cmd.iter().map(String::as_str).collect();
        args.push("--help");
        let out = og(&args);
        assert!(out.status.success(), "opengraph {args:?} failed");
        let help = String::from_utf8_lossy(&out.stdout).to_string();
        for flag in line
            .split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
            .filter(|w| w.starts_with("--") && w.len() > 2)
        {
            if !help.contains(flag) {
                missing.push(format!("opengraph {}: {flag}", cmd.join(" ")));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "flags the README shows but the binary lacks:\n{}",
        missing.join("\n")
    );
}
