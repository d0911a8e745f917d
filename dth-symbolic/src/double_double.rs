//! Double-double arithmetic (about 106 bits): [`Dd`] is an unevaluated sum `hi + lo` with
//! `|lo| <= ulp(hi) / 2`. Error-free transformations (Knuth's two-sum, fused-multiply-add
//! two-product) as in Dekker (1971) and Hida, Li and Bailey's QD library (2001); one Newton
//! correction for the quotient and the square root.
//!
//! What [`Program::value_double_double`](crate::lower::Program::value_double_double) computes
//! with (a Hamiltonian's value at a start, whose rounding would otherwise set a regularized
//! orbit's period), what a regularized `hamiltonian!` type's gradient in double-double is
//! emitted in, and the reference arithmetic of the tests. `dth-core` (which does not depend on
//! this crate) includes this file with `#[path = ...]` for the starts of runs solved in
//! double-double (`dth_core::regularize`), and so do its test trees: so it imports nothing.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// `hi + lo`, a double-double number.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd, Default)]
pub struct Dd {
    /// The leading double.
    pub hi: f64,
    /// The trailing double, at most half an ulp of `hi`.
    pub lo: f64,
}

fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

fn quick_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

impl Dd {
    /// `x` exactly.
    pub const fn new(x: f64) -> Self {
        Dd { hi: x, lo: 0.0 }
    }
    /// The double nearest `hi + lo`.
    pub fn to_f64(self) -> f64 {
        self.hi + self.lo
    }
    /// `|x|`.
    pub fn abs(self) -> Self {
        if self.hi < 0.0 {
            -self
        } else {
            self
        }
    }
    /// `sqrt(x)` (NaN below zero).
    pub fn sqrt(self) -> Self {
        // sqrt(0) = 0 (the Newton step below would divide by zero); negative gives NaN.
        if self.hi <= 0.0 {
            return Dd::new(self.hi.sqrt());
        }
        // One Newton step from the f64 square root doubles the precision.
        let x = self.hi.sqrt();
        let xd = Dd::new(x);
        let r = self - xd * xd;
        xd + Dd::new(r.hi / (2.0 * x))
    }
}

/// The largest `|2 e|` [`Dd::powf`] computes by repeated multiplication (a program's powers
/// are small integers and halves: `x^2`, `r^(-3/2)`).
const MAX_HALF_POWER: f64 = 64.0;

impl Dd {
    /// `e = m / 2` with `m` an integer of at most 64 in size: `Some(m)`, the exponents
    /// [`Dd::powf`] carries in double-double.
    pub fn exact_power(e: f64) -> Option<i32> {
        let m = 2.0 * e;
        (m == m.trunc() && m.abs() <= MAX_HALF_POWER).then_some(m as i32)
    }

    /// `x^e` in double-double where `e` is a small integer or half-integer
    /// ([`Dd::exact_power`]: by squaring, and one square root for the half); in doubles at the
    /// rounded `x` otherwise.
    pub fn powf(self, e: f64) -> Dd {
        let Some(m) = Dd::exact_power(e) else {
            return Dd::new(self.to_f64().powf(e));
        };
        // x^(m/2) = (sqrt x)^m for odd m, x^(m/2) for even m; a negative power inverts.
        let (mut base, mut n) = if m % 2 == 0 {
            (self, m.unsigned_abs() / 2)
        } else {
            (self.sqrt(), m.unsigned_abs())
        };
        let mut result = Dd::new(1.0);
        while n > 0 {
            if n & 1 == 1 {
                result = result * base;
            }
            base = base * base;
            n >>= 1;
        }
        if m < 0 {
            Dd::new(1.0) / result
        } else {
            result
        }
    }
}

impl From<f64> for Dd {
    fn from(x: f64) -> Self {
        Dd::new(x)
    }
}

impl Add for Dd {
    type Output = Dd;
    fn add(self, o: Dd) -> Dd {
        let (s1, s2) = two_sum(self.hi, o.hi);
        let (t1, t2) = two_sum(self.lo, o.lo);
        let (s1, s2) = quick_two_sum(s1, s2 + t1);
        let (hi, lo) = quick_two_sum(s1, s2 + t2);
        Dd { hi, lo }
    }
}

impl Neg for Dd {
    type Output = Dd;
    fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
}

impl Sub for Dd {
    type Output = Dd;
    fn sub(self, o: Dd) -> Dd {
        self + (-o)
    }
}

impl Mul for Dd {
    type Output = Dd;
    fn mul(self, o: Dd) -> Dd {
        let (p1, p2) = two_prod(self.hi, o.hi);
        let p2 = p2 + (self.hi * o.lo + self.lo * o.hi);
        let (hi, lo) = quick_two_sum(p1, p2);
        Dd { hi, lo }
    }
}

impl Div for Dd {
    type Output = Dd;
    fn div(self, o: Dd) -> Dd {
        // Long division: q1 + q2 + q3 with remainders computed exactly enough.
        let q1 = self.hi / o.hi;
        let r = self - o * Dd::new(q1);
        let q2 = r.hi / o.hi;
        let r = r - o * Dd::new(q2);
        let q3 = r.hi / o.hi;
        let (hi, lo) = quick_two_sum(q1, q2);
        Dd { hi, lo } + Dd::new(q3)
    }
}

#[cfg(test)]
#[test]
fn double_double_is_about_32_digits() {
    // (1 + 2^-60)^2 = 1 + 2^-59 + 2^-120: f64 loses the 2^-59 term, dd keeps it.
    let x = Dd::new(1.0) + Dd::new(2f64.powi(-60));
    let y = x * x - Dd::new(1.0);
    assert_eq!(y.hi, 2f64.powi(-59));
    // sqrt(2)^2 - 2 and (1/3) * 3 - 1 at the dd level (~1e-32).
    let two = Dd::new(2.0);
    let s = two.sqrt();
    assert!((s * s - two).to_f64().abs() < 1e-31);
    let third = Dd::new(1.0) / Dd::new(3.0);
    assert!((third * Dd::new(3.0) - Dd::new(1.0)).to_f64().abs() < 1e-31);
}
