//! `hamiltonian!`'s compile-fail cases (`tests/ui/*.rs` and the `.stderr` rustc printed), read
//! as the engine sees them: each case's expression and declared parameters ([`call`]), and
//! the diagnostics rustc printed with the byte ranges it underlines ([`diagnostics`]).
//!
//! Shared by the tests that hold the run-time paths to the macro's messages and positions:
//! `dth-runtime/tests/ui_counterparts.rs` (the engine) and
//! `dth-examples/tests/scene_ui_counterparts.rs` (a scene's `hamiltonian = "..."`), each
//! including it with `#[path]`. The cases are read from the files, so a new case is checked
//! without touching either test. Both crates sit one directory below the workspace root,
//! where [`cases`] finds `tests/ui`.
#![allow(dead_code)] // each including test uses its part

use std::fs;
use std::path::{Path, PathBuf};

/// The `.rs` files of `tests/ui`, sorted (at least 40: the directory was found).
pub fn cases() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/ui");
    let mut cases: Vec<_> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .collect();
    cases.sort();
    assert!(
        cases.len() >= 40,
        "{} cases in {}",
        cases.len(),
        dir.display()
    );
    cases
}

/// The index in [`MACRO_ONLY`] of the entry for the diagnostic `message` of `case`, if it is
/// one only the macro reports.
pub fn macro_only(case: &str, message: &str) -> Option<usize> {
    MACRO_ONLY
        .iter()
        .position(|&(c, m, _)| c == case && message.starts_with(m))
}

/// The end of the prefix of rustc's message for an engine warning (a use of a deprecated
/// constant whose note is `dth-macros`' `warning::NOTE`, then the warning): what follows it is
/// the engine's message.
pub const WARNING: &str =
    "a warning from `hamiltonian!`, not a deprecation (`#[allow(deprecated)]` silences it): ";

/// Errors only the macro reports, with the reason: `(case, start of the message)`.
pub const MACRO_ONLY: [(&str, &str, &str); 10] = [
    (
        "fallback-keeps-item-users-quiet",
        "parameter `k` must have type `f64`",
        "a Rust field type; run-time parameters are numbers",
    ),
    (
        "item-parameter-not-f64",
        "parameter `k` must have type `f64`",
        "a Rust field type; run-time parameters are numbers",
    ),
    (
        "item-generic-struct",
        "a Hamiltonian type takes no generic parameters",
        "Rust generics of the declared type",
    ),
    (
        "item-missing-eq",
        "expected `=` and the Hamiltonian",
        "the Rust item syntax around the expression",
    ),
    (
        "item-missing-name",
        "expected the type's name after `struct`",
        "the Rust item syntax around the expression",
    ),
    (
        "item-parameter-missing-colon",
        "expected `:` and the type after the parameter's name",
        "the Rust field syntax of the declared type",
    ),
    (
        "item-tuple-struct",
        "expected named parameters `{ name: f64, ... }`",
        "the Rust item syntax around the expression",
    ),
    (
        "unbalanced-paren",
        "mismatched closing delimiter",
        "rustc's tokenizer rejects the file before the macro runs; the engine's own error for \
         the same text is `unclosed (` (checked below)",
    ),
    (
        "regularize-unknown",
        "unknown regularization `polar`",
        "an attribute of the Rust item; at run time a regularization is a function \
         (`dth_symbolic::regularize`), and there is no function of an unknown name",
    ),
    (
        "greek-pi",
        "the usage of Script Group `Greek`",
        "a rustc lint warning on the source file, not a macro error",
    ),
];

/// One `error:` (or `warning:`) of a `.stderr`: its message, and the byte range rustc
/// underlines in the `.rs` file.
#[derive(Debug)]
pub struct Expected {
    /// The message.
    pub message: String,
    /// First underlined byte.
    pub start: usize,
    /// One past the last.
    pub end: usize,
}

/// The byte offset of 1-based `line` and character `column` in `text`.
pub fn offset(text: &str, line: usize, column: usize) -> usize {
    let start: usize = text
        .split_inclusive('\n')
        .take(line - 1)
        .map(str::len)
        .sum();
    let line_text = &text[start..];
    start
        + line_text
            .char_indices()
            .nth(column - 1)
            .map_or(line_text.len(), |(i, _)| i)
}

/// The diagnostics of a `.stderr`: each header line, its `-->` location, and the first
/// underline after it (the carets under the location's line).
pub fn diagnostics(stderr: &str, source: &str) -> Vec<Expected> {
    let lines: Vec<&str> = stderr.lines().collect();
    let mut out = Vec::new();
    for (k, line) in lines.iter().enumerate() {
        let message = match line
            .strip_prefix("error: ")
            .or_else(|| line.strip_prefix("warning: "))
        {
            Some(m) => m,
            None => continue,
        };
        let location = lines[k + 1]
            .split_once("--> ")
            .map(|(_, l)| l)
            .unwrap_or_else(|| panic!("no location after `{line}`"));
        let mut parts = location.rsplitn(3, ':');
        let column: usize = parts.next().unwrap().parse().unwrap();
        let row: usize = parts.next().unwrap().parse().unwrap();
        let carets = lines[k + 2..]
            .iter()
            .find_map(|l| {
                let (_, after) = l.split_once('|')?;
                let n = after.chars().filter(|&c| c == '^').count();
                (n > 0 && after.trim_start().starts_with('^')).then_some(n)
            })
            .unwrap_or_else(|| panic!("no underline after `{line}`"));
        let start = offset(source, row, column);
        out.push(Expected {
            message: message.to_string(),
            start,
            end: offset(source, row, column + carets),
        });
    }
    out
}

/// The matching close of the delimiter at byte `open` of `text` (nested delimiters and
/// string literals skipped).
pub fn matching(text: &str, open: usize) -> usize {
    let mut depth = 0;
    let mut in_string = false;
    for (i, c) in text[open..].char_indices() {
        match c {
            '"' => in_string = !in_string,
            _ if in_string => {}
            '(' | '[' | '{' => depth += 1,
            ')' | ']' | '}' => {
                depth -= 1;
                if depth == 0 {
                    return open + i;
                }
            }
            _ => {}
        }
    }
    panic!("unbalanced delimiters from byte {open}");
}

/// A macro call as the engine sees it: the expression, its byte offset in the file, and the
/// declared parameters with their offsets. `None` when the item around the expression is not
/// `struct Name { name: type, .. } = expression` (an error only the macro can report).
pub struct Call {
    /// The expression's text, as written between the delimiters.
    pub expression: String,
    /// Its byte offset in the file.
    pub at: usize,
    /// The declared parameters and their offsets in the file.
    pub params: Vec<(String, usize)>,
    /// `#[regularize(name)]` on the item: the regularization's name.
    pub regularize: Option<String>,
}

/// The macro call of `source` ([`Call`]).
pub fn call(source: &str) -> Option<Call> {
    let name = source.find("hamiltonian!").expect("a `hamiltonian!` call");
    let open = name
        + source[name..]
            .find(['(', '{'])
            .expect("the macro's delimiter");
    let close = matching(source, open);
    if source[open..].starts_with('(') {
        return Some(Call {
            expression: source[open + 1..close].to_string(),
            at: open + 1,
            params: Vec::new(),
            regularize: None,
        });
    }
    // `{ [#[regularize(name)]] [pub] struct Name [{ a: T, b: T }] = expression }`
    let item = &source[open + 1..close];
    let regularize = item.find("#[regularize(").and_then(|k| {
        let name = &item[k + "#[regularize(".len()..];
        name.find(')').map(|end| name[..end].trim().to_string())
    });
    let after_struct = item.find("struct ")? + "struct ".len();
    let rest = &item[after_struct..];
    // A unit struct: `struct Name = expression`.
    if let Some(eq) = rest.find('=').filter(|&eq| !rest[..eq].contains('{')) {
        let type_name = rest[..eq].trim();
        if type_name.is_empty() || !type_name.chars().all(|c| c.is_alphanumeric() || c == '_') {
            return None;
        }
        return Some(Call {
            expression: rest[eq + 1..].to_string(),
            at: open + 1 + after_struct + eq + 1,
            params: Vec::new(),
            regularize,
        });
    }
    let brace = rest.find('{')?;
    let type_name = rest[..brace].trim();
    if type_name.is_empty() || !type_name.chars().all(|c| c.is_alphanumeric() || c == '_') {
        return None;
    }
    let fields_open = open + 1 + after_struct + brace;
    let fields_close = matching(source, fields_open);
    let mut params = Vec::new();
    let mut cursor = fields_open + 1;
    for field in source[fields_open + 1..fields_close].split(',') {
        let (name, _ty) = field.split_once(':')?;
        // The name is the last word: `pub eps`, `pub(crate) eps`.
        let name = name.trim_end();
        let word = name.rsplit(char::is_whitespace).next().unwrap_or(name);
        params.push((word.to_string(), cursor + name.len() - word.len()));
        cursor += field.len() + 1;
    }
    let tail = &source[fields_close + 1..close];
    let eq = tail.find('=')?;
    if !tail[..eq].trim().is_empty() {
        return None;
    }
    Some(Call {
        expression: tail[eq + 1..].to_string(),
        at: fields_close + 1 + eq + 1,
        params,
        regularize,
    })
}
