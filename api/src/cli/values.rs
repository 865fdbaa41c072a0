//! The CLI's value parsers: files and folders to write (checked before any work), numbers in
//! a range, budgets, `--near`, frame ranges and `--param` values.

use std::path::PathBuf;

/// A clap parser for a file to write: its folder must exist and it must not be a folder
/// (checked before any work, so a long run never fails at its last step).
pub(crate) fn output_file(s: &str) -> Result<PathBuf, String> {
    let p = PathBuf::from(s);
    if s.is_empty() {
        return Err("the path is empty".into());
    }
    if s == "-" || p.starts_with("/dev") {
        return Ok(p);
    }
    if p.is_dir() {
        return Err(format!("{s} is a folder; give a file name"));
    }
    let parent = p.parent().filter(|d| !d.as_os_str().is_empty());
    if let Some(d) = parent
        && !d.is_dir()
    {
        return Err(format!("the folder {} does not exist", d.display()));
    }
    Ok(p)
}

/// A clap parser for `export --out`: a file to write ([`output_file`]), or a folder for a
/// format that writes one (`neo4j-csv`): an existing folder passes, and a new path needs its
/// parent folder. Which the format wants is checked once the format is known.
pub(crate) fn output_file_or_dir(s: &str) -> Result<PathBuf, String> {
    let p = PathBuf::from(s);
    if p.is_dir() {
        return Ok(p);
    }
    output_file(s)
}

/// A clap parser for a folder to write into: it may exist (as a folder) or be made, with its
/// missing parents, as long as no part of the path is a file.
pub(crate) fn output_dir(s: &str) -> Result<PathBuf, String> {
    let p = PathBuf::from(s);
    if s.is_empty() {
        return Err("the path is empty".into());
    }
    // the nearest part of the path that exists must be a folder
    let mut probe = Some(p.as_path());
    while let Some(q) = probe {
        if q.as_os_str().is_empty() {
            break;
        }
        if q.exists() {
            if !q.is_dir() {
                return Err(format!("{} exists and is not a folder", q.display()));
            }
            break;
        }
        probe = q.parent();
    }
    Ok(p)
}

/// A clap parser for a finite number in `[lo, hi]`.
pub(crate) fn in_range(lo: f64, hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone {
    move |s: &str| {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("{s:?} is not a number"))?;
        if v.is_finite() && (lo..=hi).contains(&v) {
            Ok(v)
        } else {
            Err(format!("{s} is outside [{lo}, {hi}]"))
        }
    }
}

pub(crate) fn parse_budget(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("{s:?} is not a number of seconds"))?;
    if v.is_finite() && v > 0.0 && v <= 7.0 * 86400.0 {
        Ok(v)
    } else {
        Err(format!(
            "{s}: the budget must be a finite number of seconds in (0, 604800]"
        ))
    }
}

pub(crate) fn parse_near(s: &str) -> Result<([f64; 2], f64), String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("expected X,Y,R in metres: {e}"))?;
    match v[..] {
        [x, y, r] if v.iter().all(|a| a.is_finite()) && r >= 0.0 => Ok(([x, y], r)),
        _ => Err("expected X,Y,R: three finite numbers, R >= 0".into()),
    }
}

pub(crate) fn parse_range(s: &str) -> Result<std::ops::Range<u32>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("{s:?} is not a range A..B"))?;
    let n = |x: &str| {
        x.trim()
            .parse::<u32>()
            .map_err(|_| format!("{x:?} is not a frame number"))
    };
    let (a, b) = (n(a)?, n(b)?);
    if a >= b {
        return Err(format!("{s}: the range is empty (A..B is half-open)"));
    }
    Ok(a..b)
}

pub(crate) fn parse_param(s: &str) -> Result<(String, graphstore::cypher::Val), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("--param takes name=value, got {s:?}"))?;
    let k = k.trim().trim_start_matches('$');
    if k.is_empty() || !k.chars().all(|c| c.is_alphanumeric() || c == '_') {
        return Err(format!("--param: {k:?} is not a parameter name"));
    }
    let v = graphstore::cypher::param_from_text(v).map_err(|e| format!("--param {k}: {e}"))?;
    Ok((k.to_string(), v))
}
