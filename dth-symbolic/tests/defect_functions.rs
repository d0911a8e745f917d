//! Per rule, the composition defect `T_f(a0, a1) = f'(a0) + f'(a1) - 2 (f(a1) - f(a0))/(a1 - a0)`
//! against a double-double reference. For `H = p1^2/2 + f(c + q1)` the defect's `q1`-component
//! is exactly `T_f(c + q1_0, c + q1_1)` (the argument is linear: `gbar_a = 1`, `t_a = 0`,
//! `Dg_a = 0`), so each elementary function and power form is checked on its own.
//!
//! The reference evaluates `f` and `f'` in double-double (Taylor series after halving the
//! argument, Newton's method for `ln` and `atan`), about 1e-31 relative; the divided difference
//! loses `1e-31 / delta` to cancellation and `T ~ delta^2`, so the reference keeps ~16 digits of
//! `T` down to `delta = 1e-5` (smaller steps are covered by the scaling tests in
//! `dth_symbolic::defect`).

mod common;

use common::dd::Dd;
use dth_symbolic::{compile, Method};

const EPS: f64 = f64::EPSILON;

fn d(x: f64) -> Dd {
    Dd::from(x)
}

/// `exp x`: halve to `|r| <= 1/8`, 30 Taylor terms, square back.
fn exp(x: Dd) -> Dd {
    let (mut r, mut m) = (x, 0);
    while r.hi.abs() > 0.125 {
        r = r * d(0.5);
        m += 1;
    }
    let (mut term, mut sum) = (d(1.0), d(1.0));
    for k in 1..30 {
        term = term * r / d(k as f64);
        sum = sum + term;
    }
    for _ in 0..m {
        sum = sum * sum;
    }
    sum
}

/// `(sin x, cos x)`: halve to `|r| <= 1/8`, Taylor series, double-angle formulas back.
fn sin_cos(x: Dd) -> (Dd, Dd) {
    let (mut r, mut m) = (x, 0);
    while r.hi.abs() > 0.125 {
        r = r * d(0.5);
        m += 1;
    }
    let (mut s, mut c) = (d(0.0), d(0.0));
    let mut term = d(1.0);
    for k in 0..40 {
        if k % 2 == 0 {
            c = if k % 4 == 0 { c + term } else { c - term };
        } else {
            s = if k % 4 == 1 { s + term } else { s - term };
        }
        term = term * r / d((k + 1) as f64);
    }
    for _ in 0..m {
        (s, c) = (d(2.0) * s * c, c * c - s * s);
    }
    (s, c)
}

/// `ln x`, `x > 0`: Newton on `exp y = x` from the `f64` logarithm.
fn ln(x: Dd) -> Dd {
    let mut y = d(x.hi.ln());
    for _ in 0..3 {
        let e = exp(y);
        y = y + d(2.0) * (x - e) / (x + e);
    }
    y
}

/// `atan x`: Newton on `tan y = x` from the `f64` arctangent.
fn atan(x: Dd) -> Dd {
    let mut y = d(x.hi.atan());
    for _ in 0..3 {
        let (s, c) = sin_cos(y);
        // y - (tan y - x) cos^2 y = y - (s - x c) c
        y = y - (s - x * c) * c;
    }
    y
}

/// `f` and `f'` in double-double.
fn f_and_derivative(f: &str, a: Dd) -> (Dd, Dd) {
    let one = d(1.0);
    match f {
        "exp" => (exp(a), exp(a)),
        "sin" => sin_cos(a),
        "cos" => {
            let (s, c) = sin_cos(a);
            (c, -s)
        }
        "tan" => {
            let (s, c) = sin_cos(a);
            (s / c, one / (c * c))
        }
        "sinh" | "cosh" | "tanh" => {
            let (e, ei) = (exp(a), exp(-a));
            let (sh, ch) = ((e - ei) * d(0.5), (e + ei) * d(0.5));
            match f {
                "sinh" => (sh, ch),
                "cosh" => (ch, sh),
                _ => (sh / ch, one / (ch * ch)),
            }
        }
        "ln" => (ln(a), one / a),
        "atan" => (atan(a), one / (one + a * a)),
        "sqrt" => (a.sqrt(), d(0.5) / a.sqrt()),
        // Powers a^r = exp(r ln a), r given as "pow:<r>".
        _ => {
            let r: f64 = f[4..].parse().unwrap();
            let v = exp(d(r) * ln(a));
            (v, d(r) * v / a)
        }
    }
}

/// `(T_f in f64 from the program, T_f in double-double, |f'(a0)|)`.
fn defect(src_f: &str, f: &str, c: f64, q0: f64, q1: f64) -> (f64, f64, f64) {
    let h = compile(&format!("p1^2/2 + {src_f}"), &[]).unwrap();
    let t = h
        .program(Method::DiscreteGradientDefect)
        .eval_pair(&[q0, 0.0], &[q1, 0.0], &[])
        .unwrap()
        .discrete_gradient_defect[0];
    let (a0, a1) = (d(c) + d(q0), d(c) + d(q1));
    let (f0, g0) = f_and_derivative(f, a0);
    let (f1, g1) = f_and_derivative(f, a1);
    let reference = g0 + g1 - d(2.0) * (f1 - f0) / (a1 - a0);
    (t, reference.to_f64(), g0.to_f64().abs())
}

#[test]
fn each_function_and_power_matches_double_double() {
    // (expression in q1, reference name, constant c in the argument c + q1)
    let cases: &[(&str, &str, f64)] = &[
        ("exp(q1)", "exp", 0.0),
        ("sin(q1)", "sin", 0.0),
        ("cos(q1)", "cos", 0.0),
        ("tan(q1)", "tan", 0.0),
        ("sinh(q1)", "sinh", 0.0),
        ("cosh(q1)", "cosh", 0.0),
        ("tanh(q1)", "tanh", 0.0),
        ("atan(q1)", "atan", 0.0),
        ("ln(2 + q1)", "ln", 2.0),
        ("sqrt(2 + q1)", "sqrt", 2.0),
        ("(2 + q1)^(-1)", "pow:-1", 2.0),
        ("(2 + q1)^(-3)", "pow:-3", 2.0),
        ("(2 + q1)^3", "pow:3", 2.0),
        ("(2 + q1)^6", "pow:6", 2.0),
        ("(2 + q1)^(3/2)", "pow:1.5", 2.0),
        ("(2 + q1)^(-1/2)", "pow:-0.5", 2.0),
        ("(2 + q1)^(-5/2)", "pow:-2.5", 2.0),
        ("(2 + q1)^(1/3)", "pow:0.3333333333333333", 2.0),
        ("(2 + q1)^pi", "pow:3.141592653589793", 2.0),
    ];
    let mut worst = 0.0f64;
    for &(src, f, c) in cases {
        for q0 in [0.7, -0.4] {
            // Steps in the series branches (small) and the closed forms (|delta/2| >= 1).
            for delta in [2.5, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5] {
                if f == "tan" && delta > 1.0 {
                    continue; // across the pole at pi/2
                }
                let q1 = q0 + delta;
                let (t, reference, g) = defect(src, f, c, q0, q1);
                let delta = q1 - q0;
                // A few dozen roundings of T's O(delta^2) terms, plus the rounding of the
                // argument c + q (eps |a|), which moves T by ~eps |a| delta^2 |f''''|: an
                // absolute eps delta^2 max(|f'|, 1) (|f''''| ~ |f'| for these functions on
                // these arguments).
                let scale = reference.abs() + delta * delta * g.max(1.0);
                let err = (t - reference).abs();
                assert!(
                    err <= 32.0 * EPS * scale,
                    "{src} from {q0} by {delta}: T = {t} vs double-double {reference}: {:.1} eps",
                    err / (EPS * scale)
                );
                worst = worst.max(err / (EPS * scale));
            }
        }
    }
    eprintln!("T_f vs double-double: worst {worst:.2} eps of |T| + delta^2 max(|f'|, 1)");
}
