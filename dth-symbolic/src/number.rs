//! Exact rational constants, with an `f64` fallback for irrational values (`pi`, `sin(1)`) and
//! for rationals whose numerator or denominator leaves `i128`.

use std::fmt;

/// Why folding a constant failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// A division by an expression that simplifies to zero (includes `0^-k`).
    DivisionByZero,
    /// An operation outside its real domain, e.g. `ln(-1)`, `(-8)^(1/3)`.
    Undefined(&'static str),
    /// A constant that overflows `f64`, e.g. `exp(1000)`.
    NonFinite,
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Fault::DivisionByZero => {
                f.write_str("division by zero: this divisor is (or simplifies to) 0")
            }
            Fault::Undefined(what) => write!(f, "{what}"),
            Fault::NonFinite => f.write_str("this constant overflows f64 when folded"),
        }
    }
}

/// An exact rational `num/den` in lowest terms with `den > 0`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Rational {
    num: i128,
    den: i128,
}

fn gcd(mut a: i128, mut b: i128) -> i128 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a.abs()
}

impl Rational {
    /// Zero.
    pub const ZERO: Rational = Rational { num: 0, den: 1 };
    /// One.
    pub const ONE: Rational = Rational { num: 1, den: 1 };

    /// `num/den` in lowest terms; `None` when `den == 0` or on overflow. `i128::MIN` is
    /// outside the range too, so negating or taking the magnitude of a part never overflows.
    pub fn new(num: i128, den: i128) -> Option<Self> {
        if den == 0 || num == i128::MIN || den == i128::MIN {
            return None;
        }
        let g = gcd(num, den);
        let (mut num, mut den) = (num / g, den / g);
        if den < 0 {
            num = num.checked_neg()?;
            den = den.checked_neg()?;
        }
        Some(Rational { num, den })
    }

    /// The integer `n`.
    pub const fn int(n: i128) -> Self {
        Rational { num: n, den: 1 }
    }

    /// Numerator (carries the sign).
    pub const fn numer(self) -> i128 {
        self.num
    }

    /// Denominator (positive).
    pub const fn denom(self) -> i128 {
        self.den
    }

    /// `true` for integers.
    pub const fn is_integer(self) -> bool {
        self.den == 1
    }

    /// The nearest `f64` (correctly rounded while both parts are below 2^53).
    pub fn to_f64(self) -> f64 {
        self.num as f64 / self.den as f64
    }

    fn checked_add(self, o: Self) -> Option<Self> {
        let g = gcd(self.den, o.den);
        let den = (self.den / g).checked_mul(o.den)?;
        let num = self
            .num
            .checked_mul(o.den / g)?
            .checked_add(o.num.checked_mul(self.den / g)?)?;
        Rational::new(num, den)
    }

    fn checked_mul(self, o: Self) -> Option<Self> {
        let g1 = gcd(self.num, o.den).max(1);
        let g2 = gcd(o.num, self.den).max(1);
        let num = (self.num / g1).checked_mul(o.num / g2)?;
        let den = (self.den / g2).checked_mul(o.den / g1)?;
        Rational::new(num, den)
    }

    fn checked_powi(self, k: i128) -> Option<Self> {
        let base = if k < 0 {
            Rational::new(self.den, self.num)?
        } else {
            self
        };
        let e = u32::try_from(k.unsigned_abs()).ok()?;
        Rational::new(base.num.checked_pow(e)?, base.den.checked_pow(e)?)
    }
}

impl fmt::Display for Rational {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.den == 1 {
            write!(f, "{}", self.num)
        } else {
            write!(f, "{}/{}", self.num, self.den)
        }
    }
}

/// A constant: exact when rational, `f64` otherwise.
#[derive(Clone, Copy, Debug)]
pub enum Num {
    /// An exact rational.
    Rat(Rational),
    /// A non-rational (or too large) value; never an integer below 2^53, never `-0.0`.
    Float(f64),
}

impl PartialEq for Num {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (Num::Rat(a), Num::Rat(b)) => a == b,
            (Num::Float(a), Num::Float(b)) => a.to_bits() == b.to_bits(),
            _ => false,
        }
    }
}
impl Eq for Num {}
impl std::hash::Hash for Num {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        match self {
            Num::Rat(r) => r.hash(state),
            Num::Float(x) => x.to_bits().hash(state),
        }
    }
}

const EXACT_INT: f64 = 9_007_199_254_740_992.0; // 2^53

impl Num {
    /// Zero.
    pub const ZERO: Num = Num::Rat(Rational::ZERO);
    /// One.
    pub const ONE: Num = Num::Rat(Rational::ONE);

    /// The integer `n`.
    pub const fn int(n: i128) -> Num {
        Num::Rat(Rational::int(n))
    }

    /// A float constant, normalized: integers below 2^53 become exact, `-0.0` becomes `0`.
    pub fn float(x: f64) -> Result<Num, Fault> {
        if !x.is_finite() {
            return Err(Fault::NonFinite);
        }
        if x.fract() == 0.0 && x.abs() < EXACT_INT {
            return Ok(Num::int(x as i128));
        }
        Ok(Num::Float(x))
    }

    /// The nearest `f64`.
    pub fn to_f64(self) -> f64 {
        match self {
            Num::Rat(r) => r.to_f64(),
            Num::Float(x) => x,
        }
    }

    /// The exact rational, if any.
    pub fn as_rational(self) -> Option<Rational> {
        match self {
            Num::Rat(r) => Some(r),
            Num::Float(_) => None,
        }
    }

    /// `true` for 0.
    pub fn is_zero(self) -> bool {
        self == Num::ZERO
    }

    /// `true` for 1.
    pub fn is_one(self) -> bool {
        self == Num::ONE
    }

    /// `true` when negative.
    pub fn is_negative(self) -> bool {
        self.to_f64() < 0.0
    }

    /// `self + o`, exact when both are rational.
    pub fn try_add(self, o: Num) -> Result<Num, Fault> {
        if let (Num::Rat(a), Num::Rat(b)) = (self, o) {
            if let Some(r) = a.checked_add(b) {
                return Ok(Num::Rat(r));
            }
        }
        Num::float(self.to_f64() + o.to_f64())
    }

    /// `self * o`, exact when both are rational.
    pub fn try_mul(self, o: Num) -> Result<Num, Fault> {
        if let (Num::Rat(a), Num::Rat(b)) = (self, o) {
            if let Some(r) = a.checked_mul(b) {
                return Ok(Num::Rat(r));
            }
        }
        Num::float(self.to_f64() * o.to_f64())
    }

    /// `self^e`: exact for rational powers with exact results, `powf` otherwise.
    pub fn pow(self, e: Num) -> Result<Num, Fault> {
        if self.is_zero() {
            return if e.is_negative() {
                Err(Fault::DivisionByZero)
            } else if e.is_zero() {
                Ok(Num::ONE)
            } else {
                Ok(Num::ZERO)
            };
        }
        if let (Num::Rat(b), Num::Rat(x)) = (self, e) {
            if x.is_integer() {
                if let Some(r) = b.checked_powi(x.num) {
                    return Ok(Num::Rat(r));
                }
            } else if b.num < 0 {
                return Err(Fault::Undefined(
                    "a negative constant raised to a non-integer power is undefined",
                ));
            } else if let (Some(n), Some(d)) = (exact_root(b.num, x.den), exact_root(b.den, x.den))
            {
                if let Some(r) = Rational::new(n, d).and_then(|r| r.checked_powi(x.num)) {
                    return Ok(Num::Rat(r));
                }
            }
        }
        if self.is_negative() && e.as_rational().is_none_or(|r| !r.is_integer()) {
            return Err(Fault::Undefined(
                "a negative constant raised to a non-integer power is undefined",
            ));
        }
        Num::float(self.to_f64().powf(e.to_f64()))
    }
}

impl std::ops::Neg for Num {
    type Output = Num;

    fn neg(self) -> Num {
        match self {
            Num::Rat(r) => match r.num.checked_neg().and_then(|n| Rational::new(n, r.den)) {
                Some(r) => Num::Rat(r),
                None => Num::Float(-r.to_f64()),
            },
            Num::Float(x) => Num::Float(-x),
        }
    }
}

/// The exact `k`-th root of `n >= 0`, if it is an integer.
fn exact_root(n: i128, k: i128) -> Option<i128> {
    if n < 0 || k <= 0 {
        return None;
    }
    let k = u32::try_from(k).ok()?;
    let guess = (n as f64).powf(1.0 / f64::from(k)).round() as i128;
    (guess.saturating_sub(1)..=guess + 1).find(|&r| r >= 0 && r.checked_pow(k) == Some(n))
}

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Num::Rat(r) => write!(f, "{r}"),
            Num::Float(x) => write!(f, "{x:?}"),
        }
    }
}

/// Parses a numeric literal (integer, decimal, scientific) exactly when it fits a rational.
pub fn parse_literal(text: &str) -> Result<Num, LiteralError> {
    let bytes = text.as_bytes();
    let mut i = 0;
    let mut digits = String::new();
    let mut frac_len: i64 = 0;
    while i < bytes.len() && bytes[i].is_ascii_digit() {
        digits.push(bytes[i] as char);
        i += 1;
    }
    if digits.is_empty() {
        return Err(LiteralError::Invalid);
    }
    if i < bytes.len() && bytes[i] == b'.' {
        i += 1;
        while i < bytes.len() && bytes[i].is_ascii_digit() {
            digits.push(bytes[i] as char);
            frac_len += 1;
            i += 1;
        }
    }
    let mut exp: i64 = 0;
    if i < bytes.len() && (bytes[i] == b'e' || bytes[i] == b'E') {
        i += 1;
        let neg = match bytes.get(i) {
            Some(b'-') => {
                i += 1;
                true
            }
            Some(b'+') => {
                i += 1;
                false
            }
            _ => false,
        };
        let start = i;
        while i < bytes.len() && bytes[i].is_ascii_digit() {
            i += 1;
        }
        if start == i {
            return Err(LiteralError::Invalid);
        }
        let e: i64 = text[start..i].parse().unwrap_or(i64::MAX / 4);
        exp = if neg { -e } else { e };
    }
    if i != bytes.len() {
        return Err(LiteralError::Invalid);
    }
    let value: f64 = text.parse().map_err(|_| LiteralError::Invalid)?;
    if !value.is_finite() {
        return Err(LiteralError::Overflow);
    }
    let nonzero = digits.bytes().any(|b| b != b'0');
    if nonzero && value == 0.0 {
        return Err(LiteralError::Underflow);
    }
    // Exact path: mantissa digits and power of ten both fit.
    let trimmed = digits.trim_start_matches('0');
    let pow10 = exp - frac_len;
    if trimmed.len() <= 36 && pow10.abs() <= 36 {
        let m: i128 = if trimmed.is_empty() {
            0
        } else {
            trimmed.parse().map_err(|_| LiteralError::Invalid)?
        };
        let p = 10i128.pow(pow10.unsigned_abs() as u32);
        let r = if pow10 >= 0 {
            m.checked_mul(p).and_then(|n| Rational::new(n, 1))
        } else {
            Rational::new(m, p)
        };
        if let Some(r) = r {
            return Ok(Num::Rat(r));
        }
    }
    Num::float(value).map_err(|_| LiteralError::Overflow)
}

/// Why a numeric literal was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LiteralError {
    /// Not a number of the grammar.
    Invalid,
    /// Larger than `f64::MAX`.
    Overflow,
    /// Nonzero but rounds to zero in `f64`.
    Underflow,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_are_exact_rationals() {
        assert_eq!(
            parse_literal("0.1"),
            Ok(Num::Rat(Rational::new(1, 10).unwrap()))
        );
        assert_eq!(
            parse_literal("2.5e-3"),
            Ok(Num::Rat(Rational::new(1, 400).unwrap()))
        );
        assert_eq!(parse_literal("1E3"), Ok(Num::int(1000)));
        assert_eq!(parse_literal("1e400"), Err(LiteralError::Overflow));
        assert_eq!(parse_literal("1e-400"), Err(LiteralError::Underflow));
        assert_eq!(parse_literal("0e-400"), Ok(Num::ZERO));
        assert_eq!(parse_literal("1e300"), Ok(Num::Float(1e300)));
        assert_eq!(parse_literal("2f64"), Err(LiteralError::Invalid));
    }

    #[test]
    fn powers_fold_exactly() {
        let q = |n, d| Num::Rat(Rational::new(n, d).unwrap());
        assert_eq!(q(4, 9).pow(q(-1, 2)), Ok(q(3, 2)));
        assert_eq!(q(8, 1).pow(q(2, 3)), Ok(q(4, 1)));
        assert_eq!(q(2, 1).pow(q(-3, 1)), Ok(q(1, 8)));
        assert_eq!(Num::ZERO.pow(q(-1, 1)), Err(Fault::DivisionByZero));
        assert!(matches!(q(-8, 1).pow(q(1, 3)), Err(Fault::Undefined(_))));
        assert_eq!(
            q(2, 1).pow(q(1, 2)),
            Ok(Num::Float(std::f64::consts::SQRT_2))
        );
        assert_eq!(q(1, 10).try_add(q(2, 10)), Ok(q(3, 10)));
    }
}
