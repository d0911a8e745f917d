//! Property test: nothing a user types crashes, hangs or exhausts the machine. Random token
//! streams (mostly malformed: the grammar's tokens and its usual mistakes, glued or spaced)
//! and random well-formed expression trees (every operator and function, and exponents from
//! `-1024` to `10^30` and `i128::MIN`) go through [`compile`] and, when accepted, through every
//! program and both interpreters. Each case must:
//!
//! - not panic (proptest reports a panic as a failure);
//! - stay within a fixed work bound: arena nodes and program operations (deterministic, so a
//!   hang or an explosion such as the old `k/2`-term series of `(q1 + p1)^1000000` is a
//!   failure, not a slow test), and a wall-clock bound far above any case's cost as a
//!   backstop;
//! - when rejected, carry at least one error, each on a span inside the source, on character
//!   boundaries, nonempty (unless the source is blank), with a lowercase message.

use std::time::{Duration, Instant};

use dth_symbolic::{compile, Method, Op};
use proptest::prelude::*;

/// The declared parameter of every case.
const PARAMS: [&str; 1] = ["a"];

/// Arena nodes after compiling (value, gradient, Hessian, Psi) of inputs of at most 80
/// operands; the largest seen is about 1,000.
const MAX_NODES: usize = 20_000;
/// Operations in one lowered program; the largest seen is about 17,000 (the old series for
/// `(q1 + p1)^1000000` alone emitted two million).
const MAX_OPS: usize = 100_000;
/// A backstop against hangs the counts above would miss; a case takes about a millisecond.
const MAX_TIME: Duration = Duration::from_secs(5);

/// The tokens of the grammar and of its usual mistakes.
const TOKENS: &[&str] = &[
    "q1",
    "q2",
    "p1",
    "p2",
    "q0",
    "p01",
    "q300",
    "t",
    "a",
    "x",
    "e",
    "pi",
    "π",
    "ω",
    "sin",
    "cos",
    "tan",
    "exp",
    "ln",
    "log",
    "sqrt",
    "sinh",
    "cosh",
    "tanh",
    "atan",
    "pow",
    "0",
    "1",
    "2",
    "0.5",
    "1e3",
    "2.5e-3",
    "1e400",
    "1e-400",
    "2f64",
    "2.0f64",
    "1_000",
    "2q1",
    "1024",
    "1000000",
    "170141183460469231731687303715884105727",
    "+",
    "-",
    "*",
    "/",
    "^",
    "**",
    "(",
    ")",
    ",",
    "$",
    "[",
    "]",
    "=",
    ".",
];

/// A token stream, joined with spaces or glued.
fn token_stream() -> impl Strategy<Value = String> {
    prop::collection::vec((prop::sample::select(TOKENS), any::<bool>()), 0..40).prop_map(|tokens| {
        let mut s = String::new();
        for (t, glue) in tokens {
            if !glue && !s.is_empty() {
                s.push(' ');
            }
            s.push_str(t);
        }
        s
    })
}

/// Exponents at the edges: large integers (the defect's series), negative ones, fractions,
/// huge ones that leave the exact rationals, and `(-2)^127 = i128::MIN`.
const EXPONENTS: &[&str] = &[
    "2",
    "3",
    "-1",
    "-3",
    "1/2",
    "-3/2",
    "1/3",
    "65",
    "-65",
    "1024",
    "-1024",
    "100000",
    "1000000",
    "2^100",
    "10^30",
    "(-2)^127",
    "-(-2)^127",
    "pi",
    "1e300",
];

const LEAVES: &[&str] = &[
    "q1", "q2", "p1", "p2", "q1", "q2", "p1", "p2", "t", "a", "pi", "0", "1", "2", "0.5", "1e-3",
    "1e300",
];

const FUNCTIONS: &[&str] = &[
    "sin", "cos", "tan", "exp", "ln", "sqrt", "sinh", "cosh", "tanh", "atan",
];

/// A well-formed expression, fully parenthesized: a random program of a stack machine (each
/// number pushes a leaf, or applies a function, power, sign or binary operator to the top),
/// whose stack is summed at the end; up to 80 instructions, so trees of all shapes up to ~80
/// nodes, and shrinking shortens the program.
fn expression() -> impl Strategy<Value = String> {
    prop::collection::vec(any::<u32>(), 1..80).prop_map(|program| {
        let mut stack: Vec<String> = Vec::new();
        for r in program {
            let pick = |list: &[&str]| list[(r / 16) as usize % list.len()].to_string();
            let e = match (r % 16, stack.len()) {
                (0..=5, _) | (_, 0) => pick(LEAVES),
                (6..=7, _) => format!("{}({})", pick(FUNCTIONS), stack.pop().unwrap()),
                (8..=9, _) => format!("({})^({})", stack.pop().unwrap(), pick(EXPONENTS)),
                (10, _) => format!("-{}", stack.pop().unwrap()),
                (_, 1) => pick(LEAVES),
                (k, _) => {
                    let (b, a) = (stack.pop().unwrap(), stack.pop().unwrap());
                    let op = ["+", "-", "*", "/", "^"][k as usize - 11];
                    format!("({a} {op} {b})")
                }
            };
            stack.push(e);
        }
        stack.join(" + ")
    })
}

/// Compiles `src` and, if accepted, lowers and runs every program; checks the properties.
fn check(src: &str, z: &[f64; 6]) -> Result<(), TestCaseError> {
    let start = Instant::now();
    match compile(src, &PARAMS) {
        Ok(h) => {
            let nodes = h.arena().len();
            prop_assert!(nodes <= MAX_NODES, "{src}: {nodes} arena nodes");
            // Glued tokens make any index (`p1` `0` is `p10`): the point repeats `z`.
            let z0: Vec<f64> = (0..h.dim()).map(|i| z[i % 6]).collect();
            let z1: Vec<f64> = (0..h.dim()).map(|i| z[(i + 1) % 6]).collect();
            let (z0, z1) = (&z0[..], &z1[..]);
            for m in [
                Method::All,
                Method::DiscreteGradient,
                Method::DiscreteGradientDefect,
            ] {
                let p = h.program(m);
                prop_assert!(
                    p.ops.len() <= MAX_OPS,
                    "{src} {m:?}: {} operations",
                    p.ops.len()
                );
                // The macro writes constants as literals: they must be finite.
                prop_assert!(
                    p.ops.iter().all(|op| match op {
                        Op::Const(c) | Op::Powf(_, c) => c.is_finite(),
                        _ => true,
                    }),
                    "{src} {m:?}: a constant is not finite"
                );
                if m == Method::All {
                    prop_assert!(p.eval(z0, &[0.7]).is_ok());
                } else {
                    prop_assert!(p.eval_pair(z0, z1, &[0.7]).is_ok());
                }
            }
        }
        Err(errors) => {
            prop_assert!(!errors.0.is_empty(), "{src}: rejected without an error");
            for e in &errors.0 {
                let r = e.span.range();
                prop_assert!(
                    r.start <= r.end
                        && r.end <= src.len()
                        && src.is_char_boundary(r.start)
                        && src.is_char_boundary(r.end),
                    "{src}: span {r:?} of `{e}`"
                );
                prop_assert!(
                    !r.is_empty() || src.trim().is_empty(),
                    "{src}: empty span for `{e}`"
                );
                let message = e.to_string();
                prop_assert!(
                    message.starts_with(|c: char| !c.is_uppercase()),
                    "{src}: `{message}`"
                );
            }
        }
    }
    let elapsed = start.elapsed();
    prop_assert!(elapsed <= MAX_TIME, "{src}: {elapsed:?}");
    Ok(())
}

fn point() -> impl Strategy<Value = [f64; 6]> {
    prop::array::uniform6(-2.0f64..2.0)
}

proptest! {
    // 80,000 token streams (most rejected early) and 25,000 expression trees (compiled,
    // lowered three times and run): 105,000 cases, about 20 s on two cores.
    #![proptest_config(ProptestConfig::with_cases(80_000))]

    #[test]
    fn token_streams_never_crash(src in token_stream(), z in point()) {
        check(&src, &z)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(25_000))]

    #[test]
    fn expression_trees_never_crash(h in expression(), z in point()) {
        // A momentum, so most trees are accepted and go through every program.
        check(&format!("p1^2/2 + {h}"), &z)?;
    }
}

/// Nesting up to the parser's limit (256 levels) of every construct, in the test thread's
/// small stack: compiled and run, or rejected with spanned errors, never a stack overflow.
#[test]
fn deep_nesting_never_crashes() -> Result<(), TestCaseError> {
    let z = [0.3, -0.2, 0.5, 0.1, -0.4, 0.2];
    for depth in [100, 240] {
        let mut wraps: Vec<(String, String)> = [
            "sin", "cos", "tan", "exp", "ln", "sqrt", "sinh", "cosh", "tanh", "atan",
        ]
        .iter()
        .map(|f| (format!("{f}("), ")".to_string()))
        .collect();
        for (open, close) in [
            ("(", "^2)"),
            ("(", "^(-1/2))"),
            ("(", "^q1)"),
            ("-(", ")"),
            ("1/(1 + ", ")"),
            ("(q1 + p1*", ")"),
            ("(q1*", " + p2)"),
        ] {
            wraps.push((open.to_string(), close.to_string()));
        }
        for (open, close) in &wraps {
            let src = format!("p1^2/2 + {}q1{}", open.repeat(depth), close.repeat(depth));
            check(&src, &z)?;
        }
    }
    Ok(())
}
