//! One test per differentiation and simplification rule, through the printer.

use crate::arena::Var;
use crate::error::{ErrorKind, WarningKind};
use crate::sources::toda_fixed_ends;
use crate::{compile, expression, Method};

/// `src`, simplified.
fn s(src: &str) -> String {
    let (arena, id, _) = expression(src, &["a", "b"]).unwrap_or_else(|e| panic!("{src}: {e}"));
    arena.expr(id).to_string()
}

/// `d src / d x`, simplified (`x` in the grammar's spelling).
fn d(src: &str, x: &str) -> String {
    let (mut arena, id, _) = expression(src, &["a", "b"]).unwrap_or_else(|e| panic!("{src}: {e}"));
    let v = match crate::check::resolve(x, &[]) {
        Ok(crate::check::Name::Var(v)) => v,
        _ => panic!("not a variable: {x}"),
    };
    let dx = arena.diff(id, v).unwrap();
    arena.expr(dx).to_string()
}

fn kinds(src: &str) -> Vec<ErrorKind> {
    compile(src, &["a"])
        .unwrap_err()
        .0
        .into_iter()
        .map(|e| e.kind)
        .collect()
}

// --- simplification rules -------------------------------------------------------------

#[test]
fn exact_rational_folding() {
    assert_eq!(s("1/3 + 1/6"), "1/2");
    assert_eq!(s("0.1 + 0.2"), "3/10");
    assert_eq!(s("2^10 * 4^(-1/2)"), "512");
    assert_eq!(s("(4/9)^(-3/2)"), "27/8");
}

#[test]
fn neutral_elements() {
    assert_eq!(s("q1 + 0"), "q1");
    assert_eq!(s("1*q1"), "q1");
    assert_eq!(s("q1^1"), "q1");
    assert_eq!(s("q1/1"), "q1");
    assert_eq!(s("q1^0"), "1");
}

#[test]
fn absorbing_zero() {
    assert_eq!(s("0*sin(q1)"), "0");
    assert_eq!(s("(q1 - q1)*p1"), "0");
}

#[test]
fn like_terms_collect() {
    assert_eq!(s("2*q1 + 3*q1"), "5*q1");
    assert_eq!(s("q1*p1 - p1*q1"), "0");
    assert_eq!(s("q1 + q1 + 1 + 1"), "2 + 2*q1");
}

#[test]
fn powers_merge() {
    assert_eq!(s("q1*q1"), "q1^2");
    assert_eq!(s("q1^2 * q1^(-1/2)"), "q1^(3/2)");
    assert_eq!(s("q1/q1"), "1");
    assert_eq!(s("sqrt(q1)*sqrt(q1)"), "q1");
}

#[test]
fn integer_powers_distribute_and_compose() {
    assert_eq!(s("(2*q1)^2"), "4*q1^2");
    assert_eq!(s("(q1^(1/2))^2"), "q1");
    assert_eq!(s("(q1^3)^(-2)"), "q1^(-6)");
    // (x^2)^(1/2) = |x| must not become x.
    assert_eq!(s("(q1^2)^(1/2)"), "(q1^2)^(1/2)");
}

#[test]
fn unary_minus_binds_looser_than_power() {
    assert_eq!(s("-q1^2"), "-q1^2");
    assert_eq!(s("2^-1"), "1/2");
    assert_eq!(s("2^3^2"), "512");
    assert_eq!(s("-2^2"), "-4");
}

#[test]
fn functions_of_constants_and_inverses() {
    assert_eq!(s("cos(0) + sin(0) + ln(1) + exp(0)"), "2");
    assert_eq!(s("ln(exp(q1))"), "q1");
    assert_eq!(s("exp(ln(q1))"), "q1");
    assert_eq!(s("sqrt(4)"), "2");
}

#[test]
fn variable_exponent_is_exp_of_log() {
    assert_eq!(s("q1^p1"), "exp(p1*ln(q1))");
    assert_eq!(d("q1^p1", "p1"), "ln(q1)*exp(p1*ln(q1))");
}

#[test]
fn hash_consing_shares_subexpressions() {
    let (arena, a, _) = expression("(q1^2 + q2^2)^(-1/2) + (q2^2 + q1*q1)^(-1/2)", &[]).unwrap();
    assert_eq!(arena.expr(a).to_string(), "2*(q1^2 + q2^2)^(-1/2)");
}

// --- differentiation rules ------------------------------------------------------------

#[test]
fn d_constant_and_variables() {
    assert_eq!(d("3", "q1"), "0");
    assert_eq!(d("q1", "q1"), "1");
    assert_eq!(d("q2", "q1"), "0");
    assert_eq!(d("a*q1", "q1"), "a");
    assert_eq!(d("pi*q1", "q1"), "3.141592653589793");
}

#[test]
fn d_sum_and_product() {
    assert_eq!(d("q1 + q1*p1", "q1"), "p1 + 1");
    assert_eq!(d("q1*p1*q2", "q1"), "p1*q2");
    assert_eq!(d("q1*sin(q1)", "q1"), "sin(q1) + q1*cos(q1)");
}

#[test]
fn d_powers() {
    assert_eq!(d("q1^2", "q1"), "2*q1");
    assert_eq!(d("q1^3", "q1"), "3*q1^2");
    assert_eq!(d("q1^(-1)", "q1"), "-q1^(-2)");
    assert_eq!(d("sqrt(q1)", "q1"), "(1/2)*q1^(-1/2)");
    assert_eq!(d("(q1^2+q2^2)^(-1/2)", "q1"), "-q1*(q1^2 + q2^2)^(-3/2)");
    assert_eq!(d("1/q1", "q1"), "-q1^(-2)");
}

#[test]
fn d_functions() {
    assert_eq!(d("sin(q1)", "q1"), "cos(q1)");
    assert_eq!(d("cos(q1)", "q1"), "-sin(q1)");
    assert_eq!(d("tan(q1)", "q1"), "1 + tan(q1)^2");
    assert_eq!(d("exp(2*q1)", "q1"), "2*exp(2*q1)");
    assert_eq!(d("ln(q1)", "q1"), "q1^(-1)");
    assert_eq!(d("sinh(q1)", "q1"), "cosh(q1)");
    assert_eq!(d("cosh(q1)", "q1"), "sinh(q1)");
    assert_eq!(d("tanh(q1)", "q1"), "1 - tanh(q1)^2");
    assert_eq!(d("atan(q1)", "q1"), "(1 + q1^2)^(-1)");
    assert_eq!(d("cos(q1^2)", "q1"), "-2*q1*sin(q1^2)");
}

#[test]
fn d_parameters_are_constants() {
    assert_eq!(d("a*b", "q1"), "0");
    assert_eq!(d("q1^a", "q1"), "a*exp(a*ln(q1))*q1^(-1)");
}

// --- system-level facts ---------------------------------------------------------------

#[test]
fn kepler_flags_and_hessian_sparsity() {
    let h = compile("p1^2 + p2^2 - (q1^2+q2^2)^(-1/2)", &[]).unwrap();
    assert_eq!((h.n(), h.dim()), (2, 4));
    assert!(h.separable() && !h.time_dependent() && !h.psi_identically_zero());
    // Upper triangle: q-q block (3 entries) + p1p1 + p2p2; p1p2 and the q-p block are zero.
    assert_eq!(h.outputs(Method::Hessian).len(), 5);
    assert_eq!(h.expr(h.hessian_entry(2, 2)).to_string(), "2");
}

#[test]
fn time_dependent_uses_the_extended_phase_space() {
    let h = compile("p1^2/2 + q1^2/2 - q1*cos(t)", &[]).unwrap();
    assert!(h.time_dependent());
    assert_eq!(h.coordinates(), &[Var::Q(1), Var::T, Var::P(1), Var::Pt]);
    assert_eq!(h.expr(h.gradient()[3]).to_string(), "1");
    assert_eq!(h.expr(h.gradient()[1]).to_string(), "q1*sin(t)");
    let e = h
        .program(Method::All)
        .eval(&[1.0, 0.0, 2.0, 5.0], &[])
        .unwrap();
    assert_eq!(e.value, 5.0 + 2.0 + 0.5 - 1.0);
}

#[test]
fn separable_and_psi_zero_detection() {
    assert!(!compile("q1*p1", &[]).unwrap().separable());
    assert!(compile("p1^2", &[]).unwrap().psi_identically_zero());
    assert!(compile("p1 + q1", &[]).unwrap().psi_identically_zero());
    assert!(!compile("p1^2 + q1", &[]).unwrap().psi_identically_zero());
}

#[test]
fn psi_matches_closed_form_for_the_oscillator() {
    // H = p^2/2 + k q^2/2: J grad H = (p, -k q), Psi = k p^2 + k^2 q^2 (Hess = diag(k, 1)).
    let h = compile("p1^2/2 + k*q1^2/2", &["k"]).unwrap();
    let e = h.program(Method::Psi).eval(&[0.5, -1.5], &[3.0]).unwrap();
    assert_eq!(e.psi, 3.0 * 2.25 + 9.0 * 0.25);
}

#[test]
fn programs_compute_only_what_they_need() {
    let h = compile("p1^2 + p2^2 - (q1^2+q2^2)^(-1/2)", &[]).unwrap();
    let value = h.program(Method::Value).stats();
    let all = h.program(Method::All).stats();
    assert!(value.ops < all.ops);
    // One sqrt and one division (1/r^2) serve r^(-1/2), r^(-3/2), r^(-5/2) and beyond.
    assert_eq!((all.sqrts, all.divs), (1, 1));
    assert_eq!(value.divs, 1);
}

#[test]
#[allow(clippy::print_stdout)]
fn kepler_fused_program_is_small() {
    let h = compile("p1^2 + p2^2 - (q1^2+q2^2)^(-1/2)", &[]).unwrap();
    let p = h.program(Method::All);
    println!("{p}");
    // Hand-written value+gradient+Hessian+Psi needs about 40 flops; allow modest slack.
    assert!(p.stats().ops < 60, "{:?}", p.stats());
}

// --- errors ---------------------------------------------------------------------------

#[test]
fn errors_state_the_rule_and_accumulate() {
    let e = compile("x1 + p1^2 + y", &[]).unwrap_err().0;
    assert_eq!(e.len(), 2);
    assert_eq!(
        e[0].to_string(),
        "unknown variable `x1`: expected q1..qN, p1..pN, t, or a declared parameter"
    );
    assert_eq!((e[0].span.range(), e[1].span.range()), (0..2, 12..13));
}

/// A bad parameter name is not in the source: its error says so instead of pointing at
/// bytes `0..0` of the source.
#[test]
fn parameter_errors_point_at_the_parameter_list() {
    let e = compile("p1^2/(2*m) + q1^2", &["m", "m"]).unwrap_err();
    assert_eq!(
        e.to_string(),
        "parameter `m` is declared twice (in the parameter list)"
    );
    let e = compile("p1^2 + x1", &["q1"]).unwrap_err();
    assert!(
        e.to_string().starts_with(
            "parameter `q1` is a phase-space variable (q1..qN, p1..pN, t): parameters need their \
             own names (in the parameter list); unknown variable `x1`"
        ),
        "{e}"
    );
    assert!(e.to_string().ends_with("(bytes 7..9)"), "{e}");
}

#[test]
fn structural_errors() {
    assert!(matches!(kinds("q1^2 + q2")[..], [ErrorKind::NoMomentum]));
    assert!(matches!(
        kinds("2*a + 1")[..],
        [ErrorKind::ConstantHamiltonian]
    ));
    assert!(matches!(
        kinds("p1^2 + q1^(1/0)")[..],
        [ErrorKind::Fault(crate::number::Fault::DivisionByZero)]
    ));
    assert!(matches!(
        kinds("p1^2 + ln(0)")[..],
        [ErrorKind::Fault(crate::number::Fault::Undefined(_))]
    ));
    assert!(matches!(
        kinds("p1^2 + 1e999")[..],
        [ErrorKind::LiteralOverflow { .. }]
    ));
    assert!(matches!(
        kinds("p1^2 + exp(1000)")[..],
        [ErrorKind::Fault(crate::number::Fault::NonFinite)]
    ));
}

#[test]
fn syntax_errors() {
    assert!(matches!(kinds("")[..], [ErrorKind::Empty]));
    assert!(matches!(
        kinds("p1^2 +")[..],
        [ErrorKind::ExpectedOperand { found: None }]
    ));
    assert!(matches!(kinds("(p1^2")[..], [ErrorKind::UnclosedParen]));
    assert!(matches!(kinds("p1^2)")[..], [ErrorKind::UnmatchedParen]));
    assert!(matches!(
        kinds("p1 q1")[..],
        [ErrorKind::ExpectedOperator { .. }]
    ));
    assert!(matches!(
        kinds("p1^2 + q0 + p01")[..],
        [ErrorKind::BadIndex { .. }, ErrorKind::BadIndex { .. }]
    ));
    assert!(matches!(
        kinds("p1^2 + foo(q1) + sin")[..],
        [
            ErrorKind::UnknownFunction { .. },
            ErrorKind::FunctionWithoutCall { .. }
        ]
    ));
    assert!(matches!(
        kinds("p1^2 + a(q1)")[..],
        [ErrorKind::NotAFunction { .. }]
    ));
    assert!(matches!(
        kinds("2q1 + p1^2")[..],
        [ErrorKind::InvalidNumber { .. }]
    ));
    assert!(matches!(
        kinds("p1^2 + q9999")[..],
        [ErrorKind::IndexTooLarge { .. }]
    ));
    assert!(matches!(
        kinds("p1^2 + (-8)^(1/3)")[..],
        [ErrorKind::Fault(_)]
    ));
}

#[test]
fn bad_parameters() {
    let e = compile("p1^2", &["q1", "m", "m", "sin"]).unwrap_err().0;
    assert_eq!(e.len(), 3);
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let parens = format!("p1^2 + {}q1{}", "(".repeat(300), ")".repeat(300));
    assert!(matches!(kinds(&parens)[..], [ErrorKind::TooDeep]));
    let signs = format!("p1^2 + {}q1", "-".repeat(100_000));
    assert!(matches!(kinds(&signs)[..], [ErrorKind::TooDeep]));
    let powers = format!("p1^2 + q1{}", "^q1".repeat(100_000));
    assert!(matches!(kinds(&powers)[..], [ErrorKind::TooDeep]));
    let ok = format!("p1^2 + {}q1{}", "(".repeat(200), ")".repeat(200));
    assert!(compile(&ok, &[]).is_ok());
}

#[test]
fn long_sums_build_flat() {
    // 20000 terms: the parser keeps sums flat, so neither building (recursion) nor collecting
    // like terms (one n-ary call, not one per term) grows with the length of the chain.
    let src = format!(
        "p1^2{}",
        (0..20_000)
            .map(|i| format!(" + q{}^2", i % 50 + 1))
            .collect::<String>()
    );
    let h = compile(&src, &[]).unwrap();
    assert_eq!(h.expr(h.gradient()[0]).to_string(), "800*q1");
}

#[test]
fn programs_print_one_line_per_operation() {
    let h = compile("p1^2/2 + q1^3", &[]).unwrap();
    let text = h.program(Method::Gradient).to_string();
    assert_eq!(text, "v0 = z[0]\nv1 = v0 * v0\nv2 = 3.0\nv3 = v2 * v1\nv4 = z[1]\nGradient(0) = v3\nGradient(1) = v4\n");
}

#[test]
fn dimension_and_time_dependence_follow_the_source() {
    let h = compile("p1^2 + 0*q2", &[]).unwrap();
    assert_eq!((h.n(), h.dim()), (2, 4));
    let h = compile("p1^2 + q1^2 + t - t", &[]).unwrap();
    assert!(h.time_dependent());
    assert_eq!(h.dim(), 4);
}

// --- engine work ------------------------------------------------------------------------

/// Differentiation skips subtrees free of the variable and the Hessian visits only pairs that
/// can be nonzero, so the derivative rules applied (gradient, Hessian) grow exactly linearly in
/// the Hessian's nonzeros along the chain. Walking all of `H` per coordinate, as before the
/// dependency sets, applied `O(n^2)` rules: the second difference below was positive.
#[test]
fn differentiation_work_is_linear_in_the_hessian_nonzeros() {
    let work: Vec<(usize, usize)> = (2..=20)
        .map(|n| {
            let h = compile(&toda_fixed_ends(n), &[]).unwrap();
            let nnz = h.hessian_nonzeros().len();
            assert_eq!(nnz, 3 * n - 1, "n = {n}");
            (nnz, h.arena().diff_work())
        })
        .collect();
    // Equal steps in nnz (3 per degree of freedom) must cost equal steps in work.
    let steps: Vec<isize> = work
        .windows(2)
        .map(|w| w[1].1 as isize - w[0].1 as isize)
        .collect();
    assert!(
        steps[1..].iter().all(|&s| s == steps[1]),
        "work per added degree of freedom varies: {work:?}"
    );
    let (nnz, w) = work[work.len() - 1];
    assert!(w <= 9 * nnz, "{w} rules for {nnz} nonzeros: {work:?}");
}

/// Every lowered program is free of dead operations and of repeated ones: each slot is read
/// by a later operation or is an output, and no operation appears twice.
#[test]
fn lowered_programs_have_no_dead_or_repeated_operations() {
    use crate::lower::Op;
    let sources = [
        "(p1^2 + p2^2)/(2*a) - b*(q1^2 + q2^2)^(-1/2)",
        "p1^2/(2*a*b^2) - a*b*cos(q1)",
        "(p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2*q2 - q2^3/3",
        "p1^2/2 + a^2*q1^2/2 - b*q1*cos(a*t)",
        &toda_fixed_ends(3),
    ];
    for src in sources {
        let h = compile(src, &["a", "b"]).unwrap();
        for m in [
            Method::Value,
            Method::Gradient,
            Method::Hessian,
            Method::Psi,
            Method::All,
            Method::DiscreteGradient,
        ] {
            let p = h.program(m);
            let mut used = vec![false; p.ops.len()];
            for &(_, s) in &p.outputs {
                used[s as usize] = true;
            }
            for op in &p.ops {
                let reads: &[u32] = match op {
                    Op::Add(a, b)
                    | Op::Sub(a, b)
                    | Op::Mul(a, b)
                    | Op::Div(a, b)
                    | Op::Kernel(_, a, b) => &[*a, *b],
                    Op::Neg(a) | Op::Sqrt(a) | Op::Powf(a, _) | Op::Call(_, a) => {
                        std::slice::from_ref(a)
                    }
                    _ => &[],
                };
                reads.iter().for_each(|&s| used[s as usize] = true);
            }
            assert!(used.iter().all(|&u| u), "{src} {m:?}: dead ops in\n{p}");
            let printed: Vec<String> = p
                .to_string()
                .lines()
                .filter_map(|l| l.split_once(" = "))
                .filter(|(slot, _)| slot.starts_with('v'))
                .map(|(_, op)| op.to_string())
                .collect();
            let mut unique = printed.clone();
            unique.sort();
            unique.dedup();
            assert_eq!(
                unique.len(),
                printed.len(),
                "{src} {m:?}: repeated ops in\n{p}"
            );
        }
    }
}

/// Psi from the computed gradient and Hessian slots where that is shorter: Kepler's fused
/// program spends fewer multiplications on Psi than the careful hand-fused version of the
/// bench (10), with `1/m` shared by both momenta, and agrees with Psi's own node.
#[test]
fn psi_reuses_the_gradient_and_hessian() {
    let h = compile("(p1^2 + p2^2)/(2*a) - b*(q1^2 + q2^2)^(-1/2)", &["a", "b"]).unwrap();
    let all = h.program(Method::All);
    let without_psi = crate::lower::Program::lower(
        h.arena(),
        h.coordinates(),
        &h.outputs(Method::All)
            .into_iter()
            .filter(|&(o, _)| o != crate::Output::Psi)
            .collect::<Vec<_>>(),
    );
    let psi_muls = all.stats().muls - without_psi.stats().muls;
    // w^T H w over 4 distinct entries (Hxx, Hxy, Hyy, and 1/m on both momenta): 4 squares
    // w_i^2, 1 cross product w_x w_y, 1 multiplication per distinct entry: 9 (the symbolic
    // Psi, flattened into products of all factors, took 24 operations).
    assert!(psi_muls <= 9, "{psi_muls} multiplications for Psi:\n{all}");
    let z = [0.3, -0.8, 0.5, 1.1];
    let e = all.eval(&z, &[0.7, 1.3]).unwrap();
    let direct = h.program(Method::Psi).eval(&z, &[0.7, 1.3]).unwrap();
    // Both sum the same ~5 terms of size ~10: a few ulps of 10 apart at most.
    assert!((e.psi - direct.psi).abs() <= 1e-13 * (1.0 + e.psi.abs()));
}

// --- messages for common mistakes ---------------------------------------------------------

/// Each error's message and the source text it points at.
fn messages(src: &str) -> Vec<(String, String)> {
    compile(src, &["a"])
        .unwrap_err()
        .0
        .into_iter()
        .map(|e| (e.to_string(), src[e.span.range()].to_string()))
        .collect()
}

fn one_message(src: &str) -> (String, String) {
    let m = messages(src);
    assert_eq!(m.len(), 1, "{src}: {m:?}");
    m.into_iter().next().unwrap()
}

#[test]
fn function_without_parentheses_suggests_the_call() {
    let (m, at) = one_message("p1^2 + sin q1");
    assert_eq!(at, "sin");
    assert_eq!(
        m,
        "`sin` is a function: its argument goes in parentheses, `sin(q1)`"
    );
    assert!(matches!(
        kinds("p1^2 + cos q1^2")[..],
        [ErrorKind::CallWithoutParens { ref arg, .. }] if arg == "q1^2"
    ));
}

#[test]
fn double_star_suggests_caret() {
    let (m, at) = one_message("p1**2 + q1");
    assert_eq!(at, "**");
    assert_eq!(
        m,
        "`**` is not an operator: powers are written with `^`, as in `p1^2`"
    );
    assert!(matches!(
        kinds("(q1 + p1)**(1/2)")[..],
        [ErrorKind::DoubleStar { ref power }] if power == "(q1 + p1)^(1/2)"
    ));
}

#[test]
fn functions_take_one_argument() {
    let (m, at) = one_message("p1^2 + cos(q1, q2)");
    assert_eq!(
        (m.as_str(), at.as_str()),
        ("`cos` takes one argument, found 2", "q2")
    );
    let (m, at) = one_message("p1^2 + pow(q1, 2)");
    assert_eq!(at, "pow");
    assert_eq!(
        m,
        "unknown function `pow`: powers are written with `^`, as in `q1^2`"
    );
    assert!(matches!(
        kinds("p1^2 + pow(q1 + 1, -2)")[..],
        [ErrorKind::PowFunction { ref power }] if power == "(q1 + 1)^(-2)"
    ));
    // A comma outside a call.
    let (m, at) = one_message("p1^2, q1");
    assert_eq!(at, ",");
    assert!(
        m.starts_with("unexpected `,`: a Hamiltonian is one expression"),
        "{m}"
    );
}

#[test]
fn literals_are_plain_decimals() {
    let (m, at) = one_message("p1^2 + 2.0f64*q1");
    assert_eq!(at, "2.0f64");
    assert_eq!(m, "invalid number `2.0f64`: number literals are plain decimals like `2.0` or `1000`, without a type suffix (write `2.0`)");
    let (m, _) = one_message("p1^2 + 1_000*q1");
    assert_eq!(m, "invalid number `1_000`: number literals are plain decimals like `2.0` or `1000`, without `_` (write `1000`)");
    // Glued to a variable, the hint stays the explicit `*`.
    let (m, _) = one_message("p1^2 + 2q1");
    assert_eq!(
        m,
        "invalid number `2q1`: multiplication needs an explicit `*` (write `2*q1`)"
    );
}

#[test]
fn euler_number_suggests_exp() {
    let (m, at) = one_message("p1^2 + e^q1");
    assert_eq!(at, "e");
    assert_eq!(m, "unknown variable `e`: Euler's number is not a name of the grammar, the exponential is `exp(q1)`");
    assert!(matches!(
        kinds("p1^2 + e^(-q1^2)")[..],
        [ErrorKind::EulerNumber { exponent: Some(ref x) }] if x == "-q1^2"
    ));
    assert!(matches!(
        kinds("p1^2 + 2*e")[..],
        [ErrorKind::EulerNumber { exponent: None }]
    ));
    // A declared parameter named `e` is a parameter.
    assert!(compile("p1^2 + e*q1", &["e"]).is_ok());
}

#[test]
fn greek_letters_suggest_names() {
    let (m, at) = one_message("p1^2 + π*q1");
    assert_eq!(at, "π");
    // Without the `π`, `2*π*q1` would read `2**q1`: no cascade.
    let (_, at) = one_message("p1^2 + cos(2*π*q1)");
    assert_eq!(at, "π");
    // Names are still checked.
    let both = messages("p1^2 + cos(2*π*x)");
    assert_eq!(both.len(), 2, "{both:?}");
    assert_eq!(
        m,
        "unexpected `π`: names are ASCII, the constant is written `pi`"
    );
    let (m, at) = one_message("p1^2 + ω^2*q1^2");
    assert_eq!(at, "ω");
    assert_eq!(m, "unexpected `ω`: names are ASCII: write `omega` and declare it as a parameter (`struct H { omega: f64 } = ...`)");
    let (m, _) = one_message("p1^2 + Θ");
    assert!(m.contains("`theta`"), "{m}");
    let (m, _) = one_message("p1^2 + ☃");
    assert!(m.contains("the grammar has numbers"), "{m}");
}

#[test]
fn syntax_and_name_errors_are_reported_together() {
    let m = messages("x1 + p1^2 + (q1");
    assert_eq!(m.len(), 2, "{m:?}");
    assert!(m[0].0.starts_with("unknown variable `x1`"));
    assert!(m[1].0.starts_with("unclosed `(`"));
    let m = messages("foo(q1) + p1 p1 + q0 + e^q1 + q1(2)");
    let kinds: Vec<&str> = m.iter().map(|(_, at)| at.as_str()).collect();
    assert_eq!(kinds, ["foo", "p1", "q0", "e", "q1"], "{m:?}");
    assert!(m[3].0.ends_with("`exp(q1)`"), "{m:?}");
    let m = messages("e^(q1 + p1) p1");
    assert!(m[0].0.ends_with("`exp(...)`"), "{m:?}");
    // The mistakes read past do not stop the names' errors either.
    let m = messages("sin x + p1**2");
    let at: Vec<&str> = m.iter().map(|(_, at)| at.as_str()).collect();
    assert_eq!(at, ["sin", "x", "**"], "{m:?}");
}

/// A coordinate may be absent: `p1^2/2 + p2^2/(2 q1^2) - 1/q1` (Kepler in polar coordinates)
/// has no `q2`, the angle: it is cyclic and `p2` is conserved. This is physics (so is a free
/// particle), so it compiles silently; the dimension is set by the largest index, as
/// documented. A position without its momentum never moves: a warning at it, and then a
/// momentum without its position looks like a misnumbering: a warning at it too.
#[test]
fn a_cyclic_coordinate_may_be_absent() {
    let h = compile("p1^2/2 + p2^2/(2*q1^2) - 1/q1", &[]).unwrap();
    assert_eq!(h.dim(), 4);
    assert_eq!(h.expr(h.gradient()[1]).to_string(), "0");
    assert!(h.warnings().is_empty());
    let warnings = |src| {
        let h = compile(src, &[]).unwrap();
        let w: Vec<_> = h
            .warnings()
            .iter()
            .map(|w| (w.kind.clone(), w.span.range()))
            .collect();
        w
    };
    assert_eq!(
        warnings("p1^2/2 + q1^2/2 + 0.1*q2*q1"),
        [(WarningKind::FrozenCoordinate { index: 2 }, 22..24)]
    );
    assert_eq!(
        warnings("p1^2/2 + p3^2/2 + q1^2 + q2^2"),
        [
            (
                WarningKind::Misnumbered {
                    momentum: 3,
                    position: 2
                },
                9..11
            ),
            (WarningKind::FrozenCoordinate { index: 2 }, 25..27)
        ]
    );
    // Every pair complete (or written in a term that simplifies away), or momenta alone.
    for src in [
        "p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)",
        "p1^2/2 + q1^2/2 + 0*q2*p2",
        "(p1^2 + p2^2)/2",
    ] {
        assert!(warnings(src).is_empty(), "{src}");
    }
}

/// An index with neither `q<i>` nor `p<i>` below the largest one is a misnumbering: an error
/// at the variable that sets `n`, one per run of missing indices, beside the expression's
/// other errors.
#[test]
fn a_skipped_index_is_an_error_at_the_largest() {
    let e = compile("p1^2 + p3^2 + q3 + q4^2", &[]).unwrap_err();
    let got: Vec<_> =
        e.0.iter()
            .map(|e| (e.kind.clone(), e.span.range()))
            .collect();
    let skipped = |missing| ErrorKind::SkippedIndex {
        missing,
        largest: 'q',
        n: 4,
    };
    assert_eq!(got, [(skipped(2), 19..21)]);
    assert_eq!(
        e.0[0].to_string(),
        "neither `q2` nor `p2` appears, yet `q4` makes the system's degrees of freedom 1..4: number the coordinates without gaps"
    );
    let e = compile("p1^2 + p4^2 + q4 + q1", &[]).unwrap_err();
    assert_eq!(e.0.len(), 1, "{e}");
    assert_eq!(
        e.0[0].kind,
        ErrorKind::SkippedIndices {
            first: 2,
            last: 3,
            largest: 'p',
            n: 4
        }
    );
    assert_eq!(
        e.0[0].to_string(),
        "no `q` nor `p` of the indices 2..3 appears, yet `p4` makes the system's degrees of freedom 1..4: number the coordinates without gaps"
    );
    // Reported with the structural errors of the same expression.
    let e = compile("q1 + q3", &[]).unwrap_err();
    let kinds: Vec<_> = e.0.iter().map(|e| e.kind.clone()).collect();
    assert!(kinds.contains(&ErrorKind::NoMomentum), "{e}");
    assert!(
        kinds
            .iter()
            .any(|k| matches!(k, ErrorKind::SkippedIndex { missing: 2, .. })),
        "{e}"
    );
}

/// Exponents at the edges of the exact rationals: `(-2)^127` is `i128::MIN`, whose negation
/// overflowed when the power was lowered; huge integer exponents fold to `f64` or lower in
/// `O(log k)` operations; every program's constants stay finite.
#[test]
fn extreme_exponents_compile_to_finite_programs() {
    for src in [
        "p1 + q1^((-2)^127)",
        "p1 + q1^(-(-2)^127)",
        "p1 + (q1 + 1)^((-2)^126)",
        "p1^2 + q1^(2^100)",
        "p1 + (q1^(3/7))^(10^30)",
        "p1 + q1^170141183460469231731687303715884105727",
        "p1^2/2 + q1^1024",
        "(q1 + p1)^1000000",
    ] {
        let h = compile(src, &[]).unwrap_or_else(|e| panic!("{src}: {e}"));
        for m in [
            Method::All,
            Method::DiscreteGradient,
            Method::DiscreteGradientDefect,
        ] {
            let p = h.program(m);
            assert!(
                p.ops.len() < 5000,
                "{src} {m:?}: {} operations",
                p.ops.len()
            );
            assert!(
                p.ops.iter().all(|op| match op {
                    crate::Op::Const(c) | crate::Op::Powf(_, c) => c.is_finite(),
                    _ => true,
                }),
                "{src} {m:?}: a constant overflows"
            );
        }
    }
}

/// A fault while differentiating lands on the node whose derivative failed, not on an empty
/// span at the start (found by `tests/no_input_crashes.rs`): the Hessian of `q1^(1e300)`
/// overflows.
#[test]
fn derivative_faults_are_spanned() {
    let src = "p1^2/2 + q1 + (q1)^(1e300)";
    let e = compile(src, &[]).unwrap_err().0;
    assert_eq!(e.len(), 1);
    assert!(matches!(
        e[0].kind,
        ErrorKind::Fault(crate::number::Fault::NonFinite)
    ));
    assert_eq!(&src[e[0].span.range()], "(q1)^(1e300)");
}

/// A short input whose derivatives would take gigabytes (`exp` of the product of all 512
/// variables: 131,000 Hessian entries, each a product of 512 factors) is rejected once the
/// arena passes [`crate::MAX_SIZE`], soon and on the whole expression; 20 bodies in 3D with
/// all pairwise forces stay far below the bound.
#[test]
fn derivatives_beyond_the_size_bound_are_an_error() {
    let names: Vec<String> = (1..=256)
        .map(|i| format!("q{i}"))
        .chain((1..=256).map(|i| format!("p{i}")))
        .collect();
    let src = format!("exp({})", names.join("*"));
    let start = std::time::Instant::now();
    let e = compile(&src, &[]).unwrap_err().0;
    assert!(
        matches!(e[..], [crate::Error { kind: ErrorKind::TooLarge { limit: crate::MAX_SIZE }, span }] if span.range() == (0..src.len())),
        "{e:?}"
    );
    assert!(e[0]
        .to_string()
        .contains(&format!("more than {}", crate::MAX_SIZE)));
    // Measured about 1 s in the test profile; minutes and gigabytes before the bound.
    assert!(start.elapsed().as_secs() < 30, "{:?}", start.elapsed());

    let mut nbody = String::new();
    for i in 1..=60 {
        nbody += &format!("p{i}^2/2 + ");
    }
    for i in 0..20 {
        for j in i + 1..20 {
            let d = |k: usize| format!("(q{} - q{})^2", 3 * i + k, 3 * j + k);
            nbody += &format!("- 1/sqrt({} + {} + {}) ", d(1), d(2), d(3));
        }
    }
    let h = compile(&nbody, &[]).unwrap();
    assert!(
        h.arena().size() < crate::MAX_SIZE / 5,
        "{}",
        h.arena().size()
    );
}
