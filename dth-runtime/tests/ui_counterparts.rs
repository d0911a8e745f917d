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

#[path = "../../tests/ui_cases/mod.rs"]
mod ui_cases;

use std::fs;

use ui_cases::{call, cases, diagnostics, macro_only, MACRO_ONLY, WARNING};

#[test]
fn every_ui_case_has_a_runtime_counterpart() {
    let mut used = [false; MACRO_ONLY.len()];
    let mut failures = Vec::new();
    for path in &cases() {
        let case = path.file_stem().unwrap().to_str().unwrap();
        let source = fs::read_to_string(path).unwrap();
        let stderr = fs::read_to_string(path.with_extension("stderr")).unwrap();
        let mut expected = diagnostics(&stderr, &source);
        assert!(!expected.is_empty(), "{case}: no diagnostics");
        expected.retain(|e| {
            let only = macro_only(case, &e.message);
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
        // `#[regularize(..)]`: the engine's regularization of the same text.
        let result = match call.regularize.as_deref() {
            Some("levi_civita") => dth_symbolic::regularize::levi_civita(&call.expression, &names),
            Some("kustaanheimo_stiefel") => {
                dth_symbolic::regularize::kustaanheimo_stiefel(&call.expression, &names)
            }
            // An unknown name is the macro's alone (`MACRO_ONLY`).
            Some(_) => continue,
            None => dth_symbolic::compile(&call.expression, &names),
        };
        // The engine's warnings reach rustc as uses of a deprecated constant whose note is
        // the warning (denied in these cases so trybuild shows them): compared with
        // `System::warnings`, like errors.
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
