//! Shared by the property tests: a generator of random Hamiltonian expressions with safe
//! domains (logarithms, roots and negative or fractional powers only see `1 + u^2 > 0`,
//! divisions divide by `1 + u^2`, and `exp`, `sinh`, `cosh`, `tan` only see bounded arguments
//! (`sin u`, `tanh u`), so every value and derivative is finite), its rendering in the grammar,
//! and a running error bound for the engine's programs.
#![allow(dead_code)]

use std::f64::consts::PI;

use dth_symbolic::{Func, Kernel, Op, Program, Var};
use proptest::prelude::*;

/// Oracle coordinates: x = (q1, q2, t, p1, p2, p_t).
pub const NX: usize = 6;

#[derive(Clone, Debug)]
pub enum E {
    Var(usize),
    Param,
    Const(&'static str, f64),
    Add(Box<E>, Box<E>),
    Sub(Box<E>, Box<E>),
    Mul(Box<E>, Box<E>),
    /// `a / (1 + b^2)`
    Div(Box<E>, Box<E>),
    Neg(Box<E>),
    /// `a^k`, k in 2..=4
    PowInt(Box<E>, i32),
    /// `(1 + a^2)^r` for a rational `r` written as text
    PowPos(Box<E>, &'static str, f64),
    /// `(1 + a^2)^sin(b)`: a variable exponent
    PowVar(Box<E>, Box<E>),
    Func(Func, Box<E>),
    Sqrt(Box<E>),
}

pub const CONSTS: [(&str, f64); 7] = [
    ("2", 2.0),
    ("3/2", 1.5),
    ("0.25", 0.25),
    ("2.5e-1", 0.25),
    ("pi", PI),
    ("1e1", 10.0),
    ("7", 7.0),
];
pub const EXPONENTS: [(&str, f64); 8] = [
    ("(-1)", -1.0),
    ("(-2)", -2.0),
    ("(1/2)", 0.5),
    ("(-1/2)", -0.5),
    ("(3/2)", 1.5),
    ("(-3/2)", -1.5),
    ("(1/3)", 1.0 / 3.0),
    ("(5/2)", 2.5),
];
pub const NAMES: [&str; NX] = ["q1", "q2", "t", "p1", "p2", "p_t"];

pub fn leaf() -> impl Strategy<Value = E> {
    prop_oneof![
        4 => (0..5usize).prop_map(E::Var),
        1 => Just(E::Param),
        2 => (0..CONSTS.len()).prop_map(|k| E::Const(CONSTS[k].0, CONSTS[k].1)),
    ]
}

pub fn expr() -> impl Strategy<Value = E> {
    leaf().prop_recursive(4, 24, 2, |inner| {
        let b = |e| Box::new(e);
        prop_oneof![
            (inner.clone(), inner.clone()).prop_map(move |(x, y)| E::Add(b(x), b(y))),
            (inner.clone(), inner.clone()).prop_map(move |(x, y)| E::Sub(b(x), b(y))),
            (inner.clone(), inner.clone()).prop_map(move |(x, y)| E::Mul(b(x), b(y))),
            (inner.clone(), inner.clone()).prop_map(move |(x, y)| E::Div(b(x), b(y))),
            inner.clone().prop_map(move |x| E::Neg(b(x))),
            (inner.clone(), 2..=4i32).prop_map(move |(x, k)| E::PowInt(b(x), k)),
            (inner.clone(), 0..EXPONENTS.len()).prop_map(move |(x, k)| E::PowPos(
                b(x),
                EXPONENTS[k].0,
                EXPONENTS[k].1
            )),
            (inner.clone(), inner.clone()).prop_map(move |(x, y)| E::PowVar(b(x), b(y))),
            (inner.clone(), 0..Func::ALL.len()).prop_map(move |(x, k)| E::Func(Func::ALL[k], b(x))),
            inner.prop_map(move |x| E::Sqrt(b(x))),
        ]
    })
}

/// `true` when `e` depends on a variable or the parameter.
pub fn varies(e: &E) -> bool {
    match e {
        E::Var(_) | E::Param => true,
        E::Const(..) => false,
        E::Neg(x) | E::PowInt(x, _) | E::PowPos(x, ..) | E::Func(_, x) | E::Sqrt(x) => varies(x),
        E::Add(x, y) | E::Sub(x, y) | E::Mul(x, y) | E::Div(x, y) | E::PowVar(x, y) => {
            varies(x) || varies(y)
        }
    }
}

/// `true` when every operation has a varying operand. The engine folds constant
/// subexpressions at compile time (`cos((65/16)^(3/2))` becomes one `f64`), so its run-time
/// error bound cannot see how their rounding is amplified; num-dual evaluates them at run
/// time. Excluding constant-only operations keeps the comparison about derivatives.
pub fn no_constant_operations(e: &E) -> bool {
    match e {
        E::Var(_) | E::Param | E::Const(..) => true,
        E::Neg(x) | E::PowInt(x, _) | E::PowPos(x, ..) | E::Func(_, x) | E::Sqrt(x) => {
            varies(x) && no_constant_operations(x)
        }
        E::Add(x, y) | E::Sub(x, y) | E::Mul(x, y) | E::Div(x, y) | E::PowVar(x, y) => {
            (varies(x) || varies(y)) && no_constant_operations(x) && no_constant_operations(y)
        }
    }
}

pub fn render(e: &E) -> String {
    match e {
        E::Var(i) => NAMES[*i].to_string(),
        E::Param => "a".to_string(),
        E::Const(s, _) => format!("({s})"),
        E::Add(x, y) => format!("({} + {})", render(x), render(y)),
        E::Sub(x, y) => format!("({} - {})", render(x), render(y)),
        E::Mul(x, y) => format!("({} * {})", render(x), render(y)),
        E::Div(x, y) => format!("({} / (1 + {}^2))", render(x), render(y)),
        E::Neg(x) => format!("(-{})", render(x)),
        E::PowInt(x, k) => format!("({}^{k})", render(x)),
        E::PowPos(x, r, _) => format!("((1 + {}^2)^{r})", render(x)),
        E::PowVar(x, y) => format!("((1 + {}^2)^sin({}))", render(x), render(y)),
        E::Func(f, x) => match f {
            Func::Ln => format!("ln(1 + {}^2)", render(x)),
            Func::Exp | Func::Sinh | Func::Cosh => format!("{}(sin({}))", f.name(), render(x)),
            Func::Tan => format!("tan(tanh({}))", render(x)),
            _ => format!("{}({})", f.name(), render(x)),
        },
        E::Sqrt(x) => format!("sqrt(1 + {}^2)", render(x)),
    }
}

pub fn oracle_index(v: Var) -> usize {
    match v {
        Var::Q(i) => i as usize - 1,
        Var::T => 2,
        Var::P(i) => 2 + i as usize,
        Var::Pt => 5,
        Var::Param(_) => unreachable!("parameters are not coordinates"),
    }
}

/// First-order running error bound (Higham, *Accuracy and Stability*, Sec. 3.3): for every
/// slot, `m` with |computed - exact| <= eps * m, propagating the bound of the operands through
/// the operation's partial derivatives and adding one rounding of the result (two ulps for
/// libm functions and `powf`, which are not correctly rounded).
pub fn error_bounds(p: &Program, z: &[f64], a: f64) -> Vec<f64> {
    error_bounds_pair(p, z, z, a)
}

/// [`error_bounds`] of a two-point program at `z0`, `z1`. A kernel `k(x, y)` propagates its
/// operands' bounds through `|dk/dx|` and `|dk/dy|`, estimated by central differences of the
/// kernel itself with relative step 1e-4 (the kernels are smooth and their derivatives are
/// used only as magnitudes), doubled for safety, and adds four roundings of its value (a
/// libm call, a division, and for `pow_ratio` a second call and a product).
pub fn error_bounds_pair(p: &Program, z: &[f64], z1: &[f64], a: f64) -> Vec<f64> {
    let (mut v, mut m): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    for op in &p.ops {
        let g = |s: u32| (v[s as usize], m[s as usize]);
        let (x, e) = match *op {
            Op::Input(k) => (z[k as usize], 0.0),
            Op::Input1(k) => (z1[k as usize], 0.0),
            Op::Param(_) => (a, 0.0),
            Op::Const(c) => (c, c.abs()),
            Op::Add(s, t) => {
                let ((x, mx), (y, my)) = (g(s), g(t));
                (x + y, mx + my + (x + y).abs())
            }
            Op::Sub(s, t) => {
                let ((x, mx), (y, my)) = (g(s), g(t));
                (x - y, mx + my + (x - y).abs())
            }
            Op::Mul(s, t) => {
                let ((x, mx), (y, my)) = (g(s), g(t));
                (x * y, mx * y.abs() + my * x.abs() + (x * y).abs())
            }
            Op::Div(s, t) => {
                let ((x, mx), (y, my)) = (g(s), g(t));
                (
                    x / y,
                    mx / y.abs() + my * (x / (y * y)).abs() + (x / y).abs(),
                )
            }
            Op::Neg(s) => {
                let (x, mx) = g(s);
                (-x, mx)
            }
            Op::Sqrt(s) => {
                let (x, mx) = g(s);
                (x.sqrt(), mx / (2.0 * x.sqrt()) + x.sqrt())
            }
            Op::Powf(s, r) => {
                let (x, mx) = g(s);
                let y = x.powf(r);
                (y, (r * x.powf(r - 1.0)).abs() * mx + 2.0 * y.abs())
            }
            Op::Call(f, s) => {
                let (x, mx) = g(s);
                let y = f.apply(x);
                let dy = match f {
                    Func::Sin => x.cos(),
                    Func::Cos => -x.sin(),
                    Func::Tan => 1.0 + y * y,
                    Func::Exp => y,
                    Func::Ln => 1.0 / x,
                    Func::Sinh => x.cosh(),
                    Func::Cosh => x.sinh(),
                    Func::Tanh => 1.0 - y * y,
                    Func::Atan => 1.0 / (1.0 + x * x),
                };
                (y, dy.abs() * mx + 2.0 * y.abs())
            }
            Op::Kernel(kernel, s, t) => {
                let ((x, mx), (y, my)) = (g(s), g(t));
                let k = kernel.apply(x, y);
                // The scale on which a kernel varies: the base |y| for the ratios of logarithms,
                // powers and arctangents, 1 for the others.
                let scale = match kernel {
                    Kernel::LnRatio | Kernel::PowRatio(_) | Kernel::AtanRatio => y.abs(),
                    _ => 1.0,
                };
                let partial = |f: &dyn Fn(f64) -> f64, at: f64, scale: f64| {
                    let h = 1e-4 * at.abs().max(scale);
                    2.0 * ((f(at + h) - f(at - h)) / (2.0 * h)).abs()
                };
                let (dx, dy) = if s == t {
                    (partial(&|x| kernel.apply(x, x), x, 1.0), 0.0)
                } else {
                    (
                        partial(&|x| kernel.apply(x, y), x, scale),
                        partial(&|y| kernel.apply(x, y), y, scale),
                    )
                };
                (k, dx * mx + dy * my + 4.0 * k.abs())
            }
        };
        v.push(x);
        m.push(e);
    }
    m
}

pub fn output_bound(p: &Program, bounds: &[f64], which: dth_symbolic::Output) -> f64 {
    p.outputs
        .iter()
        .find(|(o, _)| *o == which)
        .map_or(0.0, |&(_, s)| bounds[s as usize])
}

pub use dth_symbolic::double_double as dd;

/// Runs a one-point program in double-double: `None` unless every operation is carried to
/// about 2^-106 (`Program::exact_in_double_double`). Its constants are the program's `f64`s,
/// so it evaluates the same function as the program, about 2^-106 relatively.
pub fn eval_dd(p: &Program, z: &[f64], params: &[f64]) -> Option<Vec<dd::Dd>> {
    p.exact_in_double_double()
        .then(|| p.run_double_double(z, z, params))
}
