//! `--set KEY=VALUE`: change a key of a case without editing the file.
//!
//! The override is applied to the case's text (the value's characters replaced, or a line
//! added to the key's table), so the edited case goes through exactly the validation of a file,
//! and an error in an overridden value names the override. Keys are dotted paths of the case's
//! tables (`material.poisson`, `solver.end_time`, `lattice.seed`); keys of `[[...]]` arrays and
//! of inline tables are edited in the file.

use std::path::{Path, PathBuf};

use toml::de::{DeTable, DeValue};

use crate::error::{line_col, CaseError};

/// One `--set KEY=VALUE`.
#[derive(Clone, Debug, PartialEq)]
pub struct Override {
    pub key: String,
    /// The value as TOML (a bare word is taken as a string).
    pub value: String,
}

fn arg_error(arg: &str, message: impl Into<String>) -> CaseError {
    CaseError {
        file: PathBuf::from("--set"),
        line: 0,
        column: 0,
        key: arg.to_string(),
        message: message.into(),
    }
}

/// Parse `KEY=VALUE` arguments.
pub fn parse_overrides(args: &[String]) -> Result<Vec<Override>, CaseError> {
    let mut out: Vec<Override> = Vec::new();
    for a in args {
        let Some((k, v)) = a.split_once('=') else {
            return Err(arg_error(
                a,
                "give KEY=VALUE, e.g. --set material.poisson=0.3",
            ));
        };
        let (k, v) = (k.trim(), v.trim());
        let parts: Vec<&str> = k.split('.').collect();
        // A part is a name, or `name[i]` for an entry of an array of tables.
        let name_ok = |p: &str| {
            !p.is_empty()
                && p.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        };
        let part_ok = |p: &str| match p.split_once('[') {
            Some((name, rest)) => {
                name_ok(name)
                    && rest
                        .strip_suffix(']')
                        .is_some_and(|i| !i.is_empty() && i.chars().all(|c| c.is_ascii_digit()))
            }
            None => name_ok(p),
        };
        if parts.len() < 2 || !parts.iter().all(|p| part_ok(p)) {
            return Err(arg_error(
                a,
                "the key is a dotted path of a table and its key, e.g. material.poisson, solver.end_time or interfaces[0].critical_stretch",
            ));
        }
        if v.is_empty() {
            return Err(arg_error(a, "give a value after '='"));
        }
        // A value that is not TOML by itself (a bare word such as random2d) is a string.
        let value = if DeValue::parse(v).is_ok() {
            v.to_string()
        } else if !v.contains(['"', '\n', '\\']) {
            format!("\"{v}\"")
        } else {
            return Err(arg_error(
                a,
                "the value is not a TOML value (a number, a \"string\", true/false or an [array])",
            ));
        };
        if out.iter().any(|o| o.key == k) {
            return Err(arg_error(a, "this key is set twice; keep one --set"));
        }
        out.push(Override {
            key: k.to_string(),
            value,
        });
    }
    Ok(out)
}

/// Where the edits went: lines of the edited text that hold an override, and lines inserted
/// (to map error positions back to the file).
#[derive(Debug, Default)]
pub(crate) struct Edited {
    pub text: String,
    /// (1-based line in the edited text, the override) for each override.
    pub lines: Vec<(usize, Override)>,
    /// 1-based lines of the edited text that were inserted.
    pub inserted: Vec<usize>,
}

fn parse_error(file: &Path, text: &str, e: toml::de::Error) -> CaseError {
    let (line, column) = line_col(text, e.span().map_or(0, |s| s.start));
    CaseError {
        file: file.to_path_buf(),
        line,
        column,
        key: "(syntax)".into(),
        message: e.message().trim().replace('\n', " "),
    }
}

/// The span of the value `parts` names in the table `root` (`None` where the key is not
/// there), and how deep the existing tables along `parts` go.
fn find_value(
    root: &DeTable<'_>,
    parts: &[&str],
    o: &Override,
) -> Result<(Option<std::ops::Range<usize>>, usize), CaseError> {
    let mut table = root;
    let mut depth = 0;
    // Walk the tables that exist.
    let mut found = None;
    while depth < parts.len() {
        // `name[i]`: the i-th table of the array of tables `[[name]]`.
        let (name, index) = match parts[depth].split_once('[') {
            Some((name, rest)) => {
                match rest.strip_suffix(']').and_then(|i| i.parse::<usize>().ok()) {
                    Some(i) => (name, Some(i)),
                    None => (parts[depth], None),
                }
            }
            None => (parts[depth], None),
        };
        let Some((_, v)) = table.iter().find(|(k, _)| k.get_ref().as_ref() == name) else {
            break;
        };
        if let Some(i) = index {
            let entry: Option<&toml::Spanned<DeValue<'_>>> = match v.get_ref() {
                DeValue::Array(items) => items.get(i),
                _ => None,
            };
            match entry.map(toml::Spanned::get_ref) {
                Some(DeValue::Table(t)) if depth + 1 < parts.len() => {
                    table = t;
                    depth += 1;
                    continue;
                }
                _ => {
                    return Err(arg_error(
                        &format!("{}={}", o.key, o.value),
                        format!(
                            "{} is not a table of the case's [[{name}]] (they are counted from 0): give one of its keys, e.g. {name}[0].KEY",
                            parts[..=depth].join(".")
                        ),
                    ))
                }
            }
        }
        match v.get_ref() {
            DeValue::Table(t) if depth + 1 < parts.len() => {
                table = t;
                depth += 1;
            }
            DeValue::Table(_) | DeValue::Array(_)
                if depth + 1 < parts.len() || matches!(v.get_ref(), DeValue::Table(_)) =>
            {
                return Err(arg_error(
                    &format!("{}={}", o.key, o.value),
                    "this key is a table or an array of tables in the case: set one of its scalar keys, or edit [[...]] entries in the file",
                ));
            }
            _ if depth + 1 == parts.len() => {
                found = Some(v.span());
                break;
            }
            _ => {
                return Err(arg_error(
                    &format!("{}={}", o.key, o.value),
                    format!(
                        "{} is a value in the case, not a table",
                        parts[..=depth].join(".")
                    ),
                ))
            }
        }
    }
    Ok((found, depth))
}

/// Insert the key `parts` names, which the case lacks, into its table's section (or add the
/// section at the end), noting the byte offsets of the inserted lines in `inserted_at`;
/// `depth` tables along `parts` exist.
fn insert_key(
    text: &mut String,
    parts: &[&str],
    depth: usize,
    o: &Override,
    inserted_at: &mut Vec<usize>,
) -> Result<(), CaseError> {
    // Insert the key into its table's section, or add the section at the end.
    let section = parts[..parts.len() - 1].join(".");
    let key = parts[parts.len() - 1];
    let header = text
        .lines()
        .scan(0usize, |at, l| {
            let start = *at;
            *at += l.len() + 1;
            Some((start, l))
        })
        .find(|(_, l)| {
            let t = l.trim();
            t.starts_with('[')
                && !t.starts_with("[[")
                && t[1..]
                    .split(']')
                    .next()
                    .is_some_and(|h| h.trim() == section)
        });
    match header {
        Some((start, l)) => {
            let at = (start + l.len() + 1).min(text.len());
            let line = format!("{key} = {}\n", o.value);
            if at == text.len() && !text.ends_with('\n') {
                text.push('\n');
            }
            let at = at.min(text.len());
            text.insert_str(at, &line);
            inserted_at.push(at);
        }
        None if depth == parts.len() - 1 && depth > 0 => {
            return Err(arg_error(
                &format!("{}={}", o.key, o.value),
                format!(
                    "[{section}] is an inline or dotted table in the case: edit it in the file"
                ),
            ))
        }
        None => {
            if !text.ends_with('\n') {
                text.push('\n');
            }
            let at = text.len();
            text.push_str(&format!("[{section}]\n{key} = {}\n", o.value));
            inserted_at.push(at);
            inserted_at.push(at + section.len() + 3);
        }
    }
    Ok(())
}

/// Apply the overrides to the case text.
pub(crate) fn apply(file: &Path, text: &str, overrides: &[Override]) -> Result<Edited, CaseError> {
    let mut text = text.to_string();
    let mut inserted_at: Vec<usize> = Vec::new(); // byte offsets of inserted lines
    for o in overrides {
        let root = DeTable::parse(&text).map_err(|e| parse_error(file, &text, e))?;
        let parts: Vec<&str> = o.key.split('.').collect();
        let (found, depth) = find_value(root.get_ref(), &parts, o)?;
        match found {
            Some(span) => {
                text.replace_range(span.clone(), &o.value);
            }
            None if parts.iter().any(|p| p.contains('[')) => {
                return Err(arg_error(
                    &format!("{}={}", o.key, o.value),
                    "the key is not in that [[...]] entry of the case: add it there in the file (--set changes the keys an entry has)",
                ))
            }
            None => insert_key(&mut text, &parts, depth, o, &mut inserted_at)?,
        }
    }
    // Where each override stands now.
    let root = DeTable::parse(&text).map_err(|e| parse_error(file, &text, e))?;
    let mut lines = Vec::new();
    for o in overrides {
        let parts: Vec<&str> = o.key.split('.').collect();
        if let (Some(span), _) = find_value(root.get_ref(), &parts, o)? {
            lines.push((line_col(&text, span.start).0, o.clone()));
        }
    }
    let inserted = inserted_at
        .iter()
        .map(|&at| line_col(&text, at).0)
        .collect();
    Ok(Edited {
        text,
        lines,
        inserted,
    })
}

impl Edited {
    /// An error found in the edited text, told against the file and the overrides.
    pub(crate) fn map_error(&self, mut e: CaseError) -> CaseError {
        if let Some((_, o)) = self.lines.iter().find(|(l, _)| *l == e.line) {
            e.message = format!("(from --set {}={}) {}", o.key, o.value, e.message);
            e.line = 0;
            e.column = 0;
            return e;
        }
        let shift = self.inserted.iter().filter(|&&l| l < e.line).count();
        e.line -= shift.min(e.line);
        e
    }
}

/// The physics of a case as `key = value` lines, in file order: everything but `[output]` and
/// `solver.end_time`, which a resumed run may change. Checkpoints carry its digest, and
/// `run.json` the lines, so a resume with other physics names the key that differs.
pub fn physics_text(file: &Path, text: &str, overrides: &[Override]) -> Result<String, CaseError> {
    let edited = apply(file, text, overrides)?;
    let root = DeTable::parse(&edited.text).map_err(|e| parse_error(file, &edited.text, e))?;
    let mut out = String::new();
    fn walk(prefix: &str, v: &DeValue, text: &str, span: std::ops::Range<usize>, out: &mut String) {
        match v {
            DeValue::Table(t) => {
                for (k, v) in t.iter() {
                    let key = if prefix.is_empty() {
                        k.get_ref().to_string()
                    } else {
                        format!("{prefix}.{}", k.get_ref())
                    };
                    if key == "output" || key == "solver.end_time" {
                        continue;
                    }
                    walk(&key, v.get_ref(), text, v.span(), out);
                }
            }
            DeValue::Array(a)
                if a.iter().all(|e| matches!(e.get_ref(), DeValue::Table(_))) && !a.is_empty() =>
            {
                for (i, e) in a.iter().enumerate() {
                    walk(&format!("{prefix}[{i}]"), e.get_ref(), text, e.span(), out);
                }
            }
            _ => {
                let value: String = text[span].split_whitespace().collect::<Vec<_>>().join(" ");
                out.push_str(&format!("{prefix} = {value}\n"));
            }
        }
    }
    walk(
        "",
        &DeValue::Table(root.get_ref().clone()),
        &edited.text,
        0..0,
        &mut out,
    );
    Ok(out)
}
