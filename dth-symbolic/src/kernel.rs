//! The divided-difference kernels: the scalar functions `k(x, y)` that the exact discrete
//! gradient ([`crate::divided`]) and its defect ([`crate::defect`]) call where a plain quotient
//! by a difference would cancel, and the table saying which kernels each elementary function
//! uses.
//!
//! Each kernel's formula is written once, in [`Kernel::build`], over a [`Scalar`]: run on
//! `f64` it is the interpreter's [`Kernel::apply`]; run on code (the `hamiltonian!` macro
//! implements [`Scalar`] for token streams) it is the generated code. Both perform the same
//! operations in the same order, so they agree bit for bit.
//!
//! The series kernels `cos x - sin(x)/x`, `cosh x - sinh(x)/x`, `sin(x)/x - 1` and
//! `sinh(x)/x - 1` sum their even series below `|x| =` [`SERIES_SWITCH`] ([`series`],
//! [`SERIES_TERMS`] terms: the first omitted term is below `4e-19` of the leading one there)
//! and take closed forms above (cancelling at most a factor 12 at `|x| = 1`, for
//! `sinhc - 1`, and less beyond; `cosh x - sinh(x)/x` is written as
//! `(e^|x|/2) ((1 - 1/|x|) + e^(-2|x|) (1 + 1/|x|))`, a sum of positive terms).
//! [`Kernel::PowDefect`] sums `N(y)/y^3 = sum_k n_k y^(2k-2)` ([`pow_series`]) while
//! `M |y| < 1`, `M = max(|r|, |r - 2|)` (`|n_k| y^(2k)` is bounded by
//! `|r (r-2)| (M |y|)^(2k) 2k / (2k+1)!`, so the first omitted term is below `1e-18` of the
//! sum's scale), and the closed form above, where the two `sinh` terms cancel by at most
//! `3 M^2 / |r - 1|`: a relative error only for `r` near 1, where the defect itself is
//! `O(|r - 1|)`, and an absolute error of a few `eps` of the terms' size `|r (r - 2)| y`,
//! `O(delta)`, which is what the stepper needs.

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::arena::Func;

/// A divided-difference kernel `k(x, y)`: a quotient by `x` written so it has no cancellation
/// and a finite value at `x = 0` (its limit, returned exactly when `x == 0`). `x` is the
/// difference `delta = a1 - a0` of a subexpression, `y` a base (ignored by `sinc`, `sinhc` and
/// the series kernels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kernel {
    /// `(exp(y + x) - exp(y))/x`, `exp(y)` at 0: `exp(y) expm1(x)/x` for `x <= 0`, and
    /// `exp(y + x) expm1(-x)/(-x)` for `x > 0`, so the exponential is taken at the larger end
    /// and the quotient stays in (0, 1]: no `0 * inf` when `exp(y)` underflows and `x` is large.
    ExpRatio,
    /// `sin(x)/x`, 1 at 0.
    Sinc,
    /// `sinh(x)/x`, 1 at 0.
    Sinhc,
    /// `ln1p(x/y)/x = (ln(y + x) - ln y)/x`, `1/y` at 0.
    LnRatio,
    /// `atan2(x, y)/x`, `1/y` at 0.
    AtanRatio,
    /// `expm1(r ln1p(x/y))/x = ((y + x)^r - y^r)/(x y^r)`, `r/y` at 0.
    PowRatio(f64),
    /// `(tanh(y + x) - tanh y)/x`, `1 - tanh^2 y` at 0: `sinhc(x)/(cosh(y) cosh(y + x))`, or
    /// the plain quotient once `|x| > 700` (where `sinh x` would overflow and the two values
    /// are far apart, so the difference does not cancel).
    TanhRatio,
    /// `cos x - sin(x)/x` (`S(x)`, 0 at 0): the defect of `sin`, `cos` (see [`series`]).
    CosMinusSinc,
    /// `cosh x - sinh(x)/x` (`C(x)`, 0 at 0): the defect of `sinh`, `cosh`.
    CoshMinusSinhc,
    /// `sin(x)/x - 1`, 0 at 0.
    SincMinusOne,
    /// `sinh(x)/x - 1`, 0 at 0.
    SinhcMinusOne,
    /// The defect `T = f'(y) + f'(y + x) - 2 (f(y + x) - f(y))/x` of `f = exp`:
    /// `2 e^m C(x/2)`, `m = y + x/2`, from the larger end when `|x/2| >= 1`
    /// (`e^m C(h) = e^(max a) (1 - 1/|h| + ...)/2`: no overflow of `cosh h` when `e^m`
    /// underflows).
    ExpDefect,
    /// The defect `T` of `f = tanh` (as [`Kernel::ExpDefect`]):
    /// `(2 sinh m sinh(x/2) / (C0 C1))^2 - 2 (sinhc(x) - 1)/(C0 C1)`, `C = cosh`, or the plain
    /// difference after a jump of more than 700 or with both ends beyond 350.
    TanhDefect,
    /// `T / y^(r - 1)` for `f = y^r`, `r` real, `y > 0` (as [`Kernel::ExpDefect`]):
    /// `2 (y1/y)^((r-1)/2) N(u) / sinh u`, `u = ln(y1/y)/2`,
    /// `N(u) = ((r-2)/2) sinh(r u) - (r/2) sinh((r-2) u)`.
    PowDefect(f64),
}

/// Number of terms of the even series kernels.
pub const SERIES_TERMS: usize = 9;

/// Below this `|x|` the series kernels sum their series.
pub const SERIES_SWITCH: f64 = 1.0;

/// A function of `f64` a kernel formula calls, named as the `f64` method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Math {
    /// `abs(x)`
    Abs,
    /// `exp(x)`
    Exp,
    /// `exp_m1(x) = exp(x) - 1`
    ExpM1,
    /// `ln_1p(x) = ln(1 + x)`
    Ln1p,
    /// `sin(x)`
    Sin,
    /// `cos(x)`
    Cos,
    /// `sinh(x)`
    Sinh,
    /// `cosh(x)`
    Cosh,
    /// `tanh(x)`
    Tanh,
    /// `atan2(x, y)`, two arguments.
    Atan2,
    /// `max(x, y)`, two arguments.
    Max,
}

impl Math {
    /// The name of the `f64` method.
    pub fn name(self) -> &'static str {
        match self {
            Math::Abs => "abs",
            Math::Exp => "exp",
            Math::ExpM1 => "exp_m1",
            Math::Ln1p => "ln_1p",
            Math::Sin => "sin",
            Math::Cos => "cos",
            Math::Sinh => "sinh",
            Math::Cosh => "cosh",
            Math::Tanh => "tanh",
            Math::Atan2 => "atan2",
            Math::Max => "max",
        }
    }

    /// The function at `x` (and `y`, for the two-argument ones).
    pub fn apply(self, x: f64, y: f64) -> f64 {
        match self {
            Math::Abs => x.abs(),
            Math::Exp => x.exp(),
            Math::ExpM1 => x.exp_m1(),
            Math::Ln1p => x.ln_1p(),
            Math::Sin => x.sin(),
            Math::Cos => x.cos(),
            Math::Sinh => x.sinh(),
            Math::Cosh => x.cosh(),
            Math::Tanh => x.tanh(),
            Math::Atan2 => x.atan2(y),
            Math::Max => x.max(y),
        }
    }
}

/// A comparison in a kernel formula's branch condition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compare {
    /// `a == b`
    Eq,
    /// `a < b`
    Lt,
    /// `a <= b`
    Le,
    /// `a > b`
    Gt,
}

/// What a kernel formula is written over: `f64` (the interpreter evaluates it) or code (the
/// macro emits it). Arithmetic goes through the operators, functions through [`Scalar::call`];
/// every method performs exactly one `f64` operation, or none, so an implementation that
/// writes code writes the operations of the `f64` one in the same order.
pub trait Scalar:
    Clone
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// A branch condition.
    type Condition;

    /// The constant `c`.
    fn constant(c: f64) -> Self;

    /// `f(args)`: one argument, two for [`Math::Atan2`] and [`Math::Max`].
    fn call(f: Math, args: [Self; 2]) -> Self;

    /// `self op other`.
    fn compare(self, op: Compare, other: Self) -> Self::Condition;

    /// `a && b`.
    fn and(a: Self::Condition, b: Self::Condition) -> Self::Condition;

    /// `then()` if `condition` holds, else `otherwise()`; only the one taken is evaluated.
    fn select(
        condition: Self::Condition,
        then: impl FnOnce() -> Self,
        otherwise: impl FnOnce() -> Self,
    ) -> Self;

    /// `body(self)`, with `self` computed once and named `name` for reading (a `let` in code).
    fn share(self, name: &'static str, body: impl FnOnce(Self) -> Self) -> Self;
}

impl Scalar for f64 {
    type Condition = bool;

    fn constant(c: f64) -> f64 {
        c
    }

    fn call(f: Math, [x, y]: [f64; 2]) -> f64 {
        f.apply(x, y)
    }

    fn compare(self, op: Compare, other: f64) -> bool {
        match op {
            Compare::Eq => self == other,
            Compare::Lt => self < other,
            Compare::Le => self <= other,
            Compare::Gt => self > other,
        }
    }

    fn and(a: bool, b: bool) -> bool {
        a && b
    }

    fn select(condition: bool, then: impl FnOnce() -> f64, otherwise: impl FnOnce() -> f64) -> f64 {
        if condition {
            then()
        } else {
            otherwise()
        }
    }

    fn share(self, _: &'static str, body: impl FnOnce(f64) -> f64) -> f64 {
        body(self)
    }
}

/// `f(x)` of a one-argument [`Math`] function.
fn call<S: Scalar>(f: Math, x: S) -> S {
    S::call(f, [x.clone(), x])
}

/// `x == 0`.
fn is_zero<S: Scalar>(x: &S) -> S::Condition {
    x.clone().compare(Compare::Eq, S::constant(0.0))
}

/// `|x| < SERIES_SWITCH`: where the series kernels sum their series.
fn small<S: Scalar>(x: &S) -> S::Condition {
    call(Math::Abs, x.clone()).compare(Compare::Lt, S::constant(SERIES_SWITCH))
}

/// `g(x)/x`, 1 at 0 (`sinc`, `sinhc`).
fn quotient<S: Scalar>(g: Math, x: S) -> S {
    S::select(
        is_zero(&x),
        || S::constant(1.0),
        || call(g, x.clone()) / x.clone(),
    )
}

/// `(1 - 1/a) + e^(-2a) (1 + 1/a)` for `a >= 1`: `2 e^(-a) (cosh a - sinh(a)/a)`, a sum of
/// nonnegative terms.
fn cosh_minus_sinhc_scaled<S: Scalar>(a: S) -> S {
    a.share("a", |a| {
        let one = || S::constant(1.0);
        (one() - one() / a.clone())
            + call(Math::Exp, S::constant(-2.0) * a.clone()) * (one() + one() / a)
    })
}

/// `sum_k c_k x^(2k)` by Horner's rule in `x^2`.
pub fn even_series<S: Scalar>(x: S, c: &[f64; SERIES_TERMS]) -> S {
    (x.clone() * x).share("x2", |x2| {
        let mut p = S::constant(c[SERIES_TERMS - 1]);
        for &ck in c[..SERIES_TERMS - 1].iter().rev() {
            p = p * x2.clone() + S::constant(ck);
        }
        p * x2
    })
}

/// Coefficients `c_1..c_9` of `sum_k c_k x^(2k)` for the series kernels
/// ([`Kernel::CosMinusSinc`]: `(-1)^k 2k/(2k+1)!`, [`Kernel::CoshMinusSinhc`]: `2k/(2k+1)!`,
/// [`Kernel::SincMinusOne`]: `(-1)^k/(2k+1)!`, [`Kernel::SinhcMinusOne`]: `1/(2k+1)!`); zeros
/// for the other kernels.
pub fn series(kernel: Kernel) -> [f64; SERIES_TERMS] {
    let mut c = [0.0; SERIES_TERMS];
    let mut factorial = 1.0;
    for (i, c) in c.iter_mut().enumerate() {
        let k2 = 2.0 * (i as f64 + 1.0);
        factorial *= k2 * (k2 + 1.0);
        let sign = if i % 2 == 0 { -1.0 } else { 1.0 };
        *c = match kernel {
            Kernel::CosMinusSinc => sign * k2 / factorial,
            Kernel::CoshMinusSinhc => k2 / factorial,
            Kernel::SincMinusOne => sign / factorial,
            Kernel::SinhcMinusOne => 1.0 / factorial,
            _ => 0.0,
        };
    }
    c
}

/// Coefficients `n_1..n_9` of `N(y) / y^3 = sum_k n_k y^(2k-2)` for [`Kernel::PowDefect`]:
/// `n_k = r (r-2) (r^(2k) - (r-2)^(2k)) / (2 (2k+1)!)`, with the difference written as
/// `2 sum_(j odd) C(2k, j) s^j`, `s = r - 1` (terms of one sign: no cancellation for `r` near 1).
pub fn pow_series(r: f64) -> [f64; SERIES_TERMS] {
    let s = r - 1.0;
    let mut n = [0.0; SERIES_TERMS];
    let mut factorial = 1.0;
    for (i, n) in n.iter_mut().enumerate() {
        let k2 = 2 * (i + 1);
        factorial *= (k2 as f64) * (k2 as f64 + 1.0);
        let (mut binom, mut power, mut sum) = (1.0, 1.0, 0.0);
        for j in 1..=k2 {
            binom = binom * (k2 + 1 - j) as f64 / j as f64;
            power *= s;
            if j % 2 == 1 {
                sum += binom * power;
            }
        }
        *n = r * (r - 2.0) * sum / factorial;
    }
    n
}

impl Kernel {
    /// The name used when printing programs.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::ExpRatio => "exp_ratio",
            Kernel::Sinc => "sinc",
            Kernel::Sinhc => "sinhc",
            Kernel::LnRatio => "ln_ratio",
            Kernel::AtanRatio => "atan_ratio",
            Kernel::PowRatio(_) => "pow_ratio",
            Kernel::TanhRatio => "tanh_ratio",
            Kernel::CosMinusSinc => "cos_minus_sinc",
            Kernel::CoshMinusSinhc => "cosh_minus_sinhc",
            Kernel::SincMinusOne => "sinc_minus_one",
            Kernel::SinhcMinusOne => "sinhc_minus_one",
            Kernel::ExpDefect => "exp_defect",
            Kernel::TanhDefect => "tanh_defect",
            Kernel::PowDefect(_) => "pow_defect",
        }
    }

    /// The kernel as a hashable key: its name and the bits of its exponent (0 for kernels
    /// without one).
    pub(crate) fn key(self) -> (&'static str, u64) {
        let exponent = match self {
            Kernel::PowRatio(r) | Kernel::PowDefect(r) => r.to_bits(),
            _ => 0,
        };
        (self.name(), exponent)
    }

    /// `k(x, y)` in `f64`: [`Kernel::build`] on `f64`.
    ///
    /// ```
    /// use dth_symbolic::Kernel;
    /// assert_eq!(Kernel::ExpRatio.apply(0.0, 0.0), 1.0);
    /// let x = 1e-9;
    /// // (exp(x) - 1)/x to full precision, where the plain quotient keeps ~7 digits.
    /// assert!((Kernel::ExpRatio.apply(x, 0.0) - (1.0 + x / 2.0)).abs() < 1e-16);
    /// // (exp(100) - exp(-800))/900, though exp(-800) underflows and expm1(900) overflows.
    /// let r = Kernel::ExpRatio.apply(900.0, -800.0);
    /// assert!((r / (100f64.exp() / 900.0) - 1.0).abs() < 1e-13);
    /// assert!((Kernel::LnRatio.apply(0.0, 4.0) - 0.25).abs() == 0.0);
    /// ```
    pub fn apply(self, x: f64, y: f64) -> f64 {
        self.build(x, y)
    }

    /// `k(x, y)` over any [`Scalar`]: the one definition of every kernel's formula.
    pub fn build<S: Scalar>(self, x: S, y: S) -> S {
        let c = S::constant;
        match self {
            Kernel::ExpRatio => S::select(
                is_zero(&x),
                || call(Math::Exp, y.clone()),
                || {
                    S::select(
                        x.clone().compare(Compare::Lt, c(0.0)),
                        || call(Math::Exp, y.clone()) * (call(Math::ExpM1, x.clone()) / x.clone()),
                        || {
                            call(Math::Exp, y.clone() + x.clone())
                                * (call(Math::ExpM1, -x.clone()) / -x.clone())
                        },
                    )
                },
            ),
            Kernel::Sinc => quotient(Math::Sin, x),
            Kernel::Sinhc => quotient(Math::Sinh, x),
            Kernel::LnRatio => (x.clone() / y.clone()).share("u", |u| {
                S::select(
                    is_zero(&u),
                    || c(1.0) / y.clone(),
                    || call(Math::Ln1p, u.clone()) / x.clone(),
                )
            }),
            Kernel::AtanRatio => S::select(
                is_zero(&x),
                || c(1.0) / y.clone(),
                || S::call(Math::Atan2, [x.clone(), y.clone()]) / x.clone(),
            ),
            Kernel::PowRatio(r) => (x.clone() / y.clone()).share("u", |u| {
                S::select(
                    is_zero(&u),
                    || c(r) / y.clone(),
                    || call(Math::ExpM1, c(r) * call(Math::Ln1p, u.clone())) / x.clone(),
                )
            }),
            Kernel::TanhRatio => S::select(
                call(Math::Abs, x.clone()).compare(Compare::Gt, c(700.0)),
                || {
                    (call(Math::Tanh, y.clone() + x.clone()) - call(Math::Tanh, y.clone()))
                        / x.clone()
                },
                || {
                    Kernel::Sinhc.build(x.clone(), x.clone())
                        / (call(Math::Cosh, y.clone()) * call(Math::Cosh, y.clone() + x.clone()))
                },
            ),
            Kernel::CosMinusSinc => S::select(
                small(&x),
                || even_series(x.clone(), &series(self)),
                || call(Math::Cos, x.clone()) - call(Math::Sin, x.clone()) / x.clone(),
            ),
            Kernel::CoshMinusSinhc => S::select(
                small(&x),
                || even_series(x.clone(), &series(self)),
                || {
                    let a = call(Math::Abs, x.clone());
                    c(0.5) * call(Math::Exp, a.clone()) * cosh_minus_sinhc_scaled(a)
                },
            ),
            Kernel::SincMinusOne => S::select(
                small(&x),
                || even_series(x.clone(), &series(self)),
                || call(Math::Sin, x.clone()) / x.clone() - c(1.0),
            ),
            Kernel::SinhcMinusOne => S::select(
                small(&x),
                || even_series(x.clone(), &series(self)),
                || call(Math::Sinh, x.clone()) / x.clone() - c(1.0),
            ),
            // x = delta, y = a0: 2 e^m C(delta/2).
            Kernel::ExpDefect => (c(0.5) * x.clone()).share("h", |h| {
                S::select(
                    small(&h),
                    || {
                        c(2.0)
                            * call(Math::Exp, y.clone() + h.clone())
                            * even_series(h.clone(), &series(Kernel::CoshMinusSinhc))
                    },
                    || {
                        let top = S::call(Math::Max, [x.clone(), c(0.0)]);
                        call(Math::Exp, y.clone() + top)
                            * cosh_minus_sinhc_scaled(call(Math::Abs, h.clone()))
                    },
                )
            }),
            Kernel::TanhDefect => (y.clone() + c(0.5) * x.clone()).share("m", |m| {
                (c(1.0) / call(Math::Cosh, y.clone())).share("s0", |s0| {
                    (c(1.0) / call(Math::Cosh, y.clone() + x.clone())).share("s1", |s1| {
                        S::select(
                            S::and(
                                call(Math::Abs, x.clone()).compare(Compare::Le, c(700.0)),
                                call(Math::Abs, m.clone()).compare(Compare::Le, c(350.0)),
                            ),
                            // Every cosh and sinh below finite (|a| <= 700); the factors are
                            // ordered so the partial products stay finite.
                            || {
                                let q = c(2.0)
                                    * call(Math::Sinh, m.clone())
                                    * s0.clone()
                                    * call(Math::Sinh, c(0.5) * x.clone())
                                    * s1.clone();
                                q.share("q", |q| {
                                    q.clone() * q
                                        - c(2.0)
                                            * Kernel::SinhcMinusOne.build(x.clone(), x.clone())
                                            * s0.clone()
                                            * s1.clone()
                                })
                            },
                            // A jump of more than 700 (the values are far apart: no
                            // cancellation), or both ends beyond |a| = 350, where every term
                            // is below 1e-300.
                            || {
                                s0.clone() * s0.clone() + s1.clone() * s1.clone()
                                    - c(2.0) * Kernel::TanhRatio.build(x.clone(), y.clone())
                            },
                        )
                    })
                })
            }),
            Kernel::PowDefect(r) => {
                (c(0.5) * call(Math::Ln1p, x.clone() / y.clone())).share("u", |u| {
                    let big = r.abs().max((r - 2.0).abs());
                    let ratio = S::select(
                        (c(big) * call(Math::Abs, u.clone()))
                            .compare(Compare::Lt, c(SERIES_SWITCH)),
                        || {
                            even_series(u.clone(), &pow_series(r))
                                / Kernel::Sinhc.build(u.clone(), u.clone())
                        },
                        || {
                            (c(0.5 * (r - 2.0)) * call(Math::Sinh, c(r) * u.clone())
                                - c(0.5 * r) * call(Math::Sinh, c(r - 2.0) * u.clone()))
                                / call(Math::Sinh, u.clone())
                        },
                    );
                    c(2.0) * call(Math::Exp, c(r - 1.0) * u) * ratio
                })
            }
        }
    }
}

/// The midpoint rules of `sin`, `cos`, `sinh`, `cosh`: `f' = sign partner`, `f'' = curvature
/// f`; the divided difference is `f'(mean) ratio(delta/2)` and the defect
/// `2 f'(mean) defect(delta/2)`, with `f''(mean) 2 odd(delta/2)` for `f'(u1) - f'(u0)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Midpoint {
    /// The function whose multiple is `f'`.
    pub(crate) partner: Func,
    /// `f' = sign partner`, `sign = +-1`.
    pub(crate) sign: f64,
    /// `f'' = curvature f`, `curvature = +-1`.
    pub(crate) curvature: f64,
    /// `sinc` or `sinhc`.
    pub(crate) ratio: Kernel,
    /// `cos x - sin(x)/x` or `cosh x - sinh(x)/x`.
    pub(crate) defect: Kernel,
    /// `sin` or `sinh`.
    pub(crate) odd: Func,
}

impl Midpoint {
    /// `sin' = cos`, `sin'' = -sin`.
    pub(crate) const SIN: Midpoint = Midpoint::circular(Func::Cos, 1.0);
    /// `cos' = -sin`, `cos'' = -cos`.
    pub(crate) const COS: Midpoint = Midpoint::circular(Func::Sin, -1.0);
    /// `sinh' = cosh`, `sinh'' = sinh`.
    pub(crate) const SINH: Midpoint = Midpoint::hyperbolic(Func::Cosh);
    /// `cosh' = sinh`, `cosh'' = cosh`.
    pub(crate) const COSH: Midpoint = Midpoint::hyperbolic(Func::Sinh);

    const fn circular(partner: Func, sign: f64) -> Midpoint {
        Midpoint {
            partner,
            sign,
            curvature: -1.0,
            ratio: Kernel::Sinc,
            defect: Kernel::CosMinusSinc,
            odd: Func::Sin,
        }
    }

    const fn hyperbolic(partner: Func) -> Midpoint {
        Midpoint {
            partner,
            sign: 1.0,
            curvature: 1.0,
            ratio: Kernel::Sinhc,
            defect: Kernel::CoshMinusSinhc,
            odd: Func::Sinh,
        }
    }
}
