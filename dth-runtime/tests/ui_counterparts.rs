//! Every compile-fail case of `hamiltonian!` (`tests/ui/*.rs` and the `.stderr` rustc
//! printed) has a run-time counterpart: [`dth_symbolic::compile`] on the same text, with the
//! same parameter names, gives the same messages, in the same order, and each error's byte
//! span starts where the macro's underline starts and ends where it ends; so do the engine's
//! warnings (`System::warnings`), which the macro turns into compiler warnings.
//!
//! The cases are read from the files, so a new case is checked without touching this test.
//! What only the macro can see (the Rust item around the expression: field types, generics,
//! tuple structs, a missing `=` or name, rustc's own token errors) is listed in
//! [`MACRO_ONLY`] with the reason; every entry must match an error of its case, so the list
//! cannot go stale. Where the two differ by construction, the test says so:
//!
//! - text: the macro underlines whole Rust tokens, a run-time error the piece of text at
//!   fault; a warning, only the first token of the engine's span (`q` of `q[i]`). A string literal `"q1"` is one Rust token, and an error at its quote is
//!   underlined to its end by rustc; the brackets of `[q1 + q2]` are one Rust group. So the
//!   end of an error is compared only where the two tokenizations agree, the start always.
//! - the empty expression: there is no token; the macro points at the call, a run-time error
//!   at byte 0 of the empty text.
//! - parameters are not in the text at run time (they are names beside it): their errors
//!   carry no position; the macro's points at the parameter of that name in the struct.

use std::fs;
use std::path::Path;

/// Errors only the macro reports, with the reason: `(case, start of the message)`.
const MACRO_ONLY: [(&str, &str, &str); 9] = [
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
        "greek-pi",
        "the usage of Script Group `Greek`",
        "a rustc lint warning on the source file, not a macro error",
    ),
];

/// One `error:` (or `warning:`) of a `.stderr`: its message, and the byte range rustc
/// underlines in the `.rs` file.
#[derive(Debug)]
struct Expected {
    message: String,
    start: usize,
    end: usize,
}

/// The byte offset of 1-based `line` and character `column` in `text`.
fn offset(text: &str, line: usize, column: usize) -> usize {
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
fn diagnostics(stderr: &str, source: &str) -> Vec<Expected> {
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
fn matching(text: &str, open: usize) -> usize {
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
struct Call {
    expression: String,
    at: usize,
    params: Vec<(String, usize)>,
}

fn call(source: &str) -> Option<Call> {
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
        });
    }
    // `{ [pub] struct Name { a: T, b: T } = expression }`
    let item = &source[open + 1..close];
    let after_struct = item.find("struct ")? + "struct ".len();
    let rest = &item[after_struct..];
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
    })
}

#[test]
fn every_ui_case_has_a_runtime_counterpart() {
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
    let mut used = [false; MACRO_ONLY.len()];
    let mut failures = Vec::new();
    for path in &cases {
        let case = path.file_stem().unwrap().to_str().unwrap();
        let source = fs::read_to_string(path).unwrap();
        let stderr = fs::read_to_string(path.with_extension("stderr")).unwrap();
        let mut expected = diagnostics(&stderr, &source);
        assert!(!expected.is_empty(), "{case}: no diagnostics");
        expected.retain(|e| {
            let only = MACRO_ONLY
                .iter()
                .position(|&(c, m, _)| c == case && e.message.starts_with(m));
            if let Some(k) = only {
                used[k] = true;
            }
            only.is_none()
        });
        if case == "unbalanced-paren" {
            // The file does not tokenize, so its call has no extent: the text the user meant
            // is the line's, up to the `)` that closes the macro instead.
            let errors = dth_symbolic::compile("(p1^2 + q1", &[]).unwrap_err();
            assert_eq!(
                errors.0[0].to_string(),
                "unclosed `(`: expected a matching `)`"
            );
            assert_eq!(errors.0[0].span.start, 0, "{case}: at the `(`");
            continue;
        }
        let Some(call) = call(&source) else {
            assert!(
                expected.is_empty(),
                "{case}: the item does not parse, yet {expected:?}"
            );
            continue;
        };
        let names: Vec<&str> = call.params.iter().map(|(n, _)| n.as_str()).collect();
        let result = dth_symbolic::compile(&call.expression, &names);
        // The engine's warnings reach rustc as uses of a deprecated constant whose note is
        // the warning (denied in these cases so trybuild shows them): compared with
        // `System::warnings`, like errors.
        const WARNING: &str = "hamiltonian_warning`: ";
        for e in &mut expected {
            if let Some((_, warning)) = e.message.split_once(WARNING) {
                e.message = warning.to_string();
            }
        }
        // (message, span, the parameter an error is about)
        let result_is_ok = result.is_ok();
        let found: Vec<(String, std::ops::Range<usize>, Option<String>)> = match result {
            Err(e) => e
                .0
                .iter()
                .map(|e| {
                    let parameter = match &e.kind {
                        dth_symbolic::ErrorKind::BadParameter { name, .. } => Some(name.clone()),
                        _ => None,
                    };
                    (e.to_string(), e.span.range(), parameter)
                })
                .collect(),
            Ok(system) => system
                .warnings()
                .iter()
                .map(|w| (w.to_string(), w.span.range(), None))
                .collect(),
        };
        let messages: Vec<&str> = found.iter().map(|f| f.0.as_str()).collect();
        let wanted: Vec<&str> = expected.iter().map(|e| e.message.as_str()).collect();
        if messages != wanted {
            failures.push(format!("{case}: {messages:?} instead of {wanted:?}"));
            continue;
        }
        for ((message, span, parameter), want) in found.iter().zip(&expected) {
            if let Some(name) = parameter {
                let at = call
                    .params
                    .iter()
                    .find(|(n, at)| n == name && *at == want.start);
                assert!(
                    at.is_some(),
                    "{case}: the macro points at parameter `{name}`"
                );
                continue;
            }
            if call.expression.trim().is_empty() {
                assert_eq!(*span, 0..0, "{case}");
                continue;
            }
            let (start, end) = (call.at + span.start, call.at + span.end);
            // A warning reaches rustc as the use of a deprecated constant, which rustc
            // underlines as one token (stable proc macros cannot join spans): the first token
            // of the engine's span (`q` of `q[i]`).
            let warning = result_is_ok && want.end <= end && want.end > want.start;
            if start != want.start || (!warning && end != want.end) {
                failures.push(format!(
                    "{case}: `{message}` at {:?}, the macro at {:?}",
                    &source[start..end],
                    &source[want.start..want.end]
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    for (k, &(case, message, why)) in MACRO_ONLY.iter().enumerate() {
        assert!(used[k], "stale entry: {case}: `{message}` ({why})");
    }
}
