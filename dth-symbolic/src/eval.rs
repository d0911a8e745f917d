//! The interpreter: runs a [`Program`] on `f64`s. It tests the engine without a compiler and
//! is the run-time path for Hamiltonians read from text.

use crate::double_double::Dd;
use crate::error::EvalError;
use crate::lower::{Op, Output, Program};

/// The outputs of one run; what the program does not compute is zero.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// `H(z)`.
    pub value: f64,
    /// `grad H`, length `D`.
    pub gradient: Vec<f64>,
    /// `Hess H`, `D x D` row-major, both triangles filled.
    pub hessian: Vec<f64>,
    /// Psi.
    pub psi: f64,
}

/// The outputs of one run of a two-point program (`Method::DiscreteGradient`).
#[derive(Clone, Debug, PartialEq)]
pub struct PairEvaluation {
    /// `gbar(z0, z1)`, length `D`.
    pub discrete_gradient: Vec<f64>,
    /// `H(z1) - H(z0)`, computed without cancellation.
    pub energy_difference: f64,
    /// `grad H(z0) + grad H(z1) - 2 gbar(z0, z1)`, length `D` (zeros unless the program is
    /// `Method::DiscreteGradientDefect`).
    pub discrete_gradient_defect: Vec<f64>,
}

impl Program {
    /// Runs the program at `z` with parameter values `params` (a two-point program runs with
    /// `z0 = z1 = z`).
    ///
    /// ```
    /// use dth_symbolic::{compile, Method};
    /// let h = compile("p1^2/(2*m) + q1^4", &["m"]).unwrap();
    /// let e = h.program(Method::All).eval(&[1.0, 3.0], &[0.5]).unwrap();
    /// assert_eq!((e.value, e.gradient[0], e.gradient[1]), (10.0, 4.0, 6.0));
    /// assert_eq!(e.hessian, vec![12.0, 0.0, 0.0, 2.0]);
    /// ```
    pub fn eval(&self, z: &[f64], params: &[f64]) -> Result<Evaluation, EvalError> {
        self.check_lengths(&[("z", z)], params)?;
        let v = self.run(z, z, params);
        let d = self.dim;
        let mut e = Evaluation {
            value: 0.0,
            gradient: vec![0.0; d],
            hessian: vec![0.0; d * d],
            psi: 0.0,
        };
        for &(out, s) in &self.outputs {
            let x = v[s as usize];
            match out {
                Output::Value => e.value = x,
                Output::Gradient(i) => e.gradient[i] = x,
                Output::Hessian(i, j) => {
                    e.hessian[i * d + j] = x;
                    e.hessian[j * d + i] = x;
                }
                Output::Psi => e.psi = x,
                Output::DiscreteGradient(_)
                | Output::EnergyDifference
                | Output::DiscreteGradientDefect(_) => {}
            }
        }
        Ok(e)
    }

    /// Runs a two-point program (a discrete gradient) at `z0`, `z1` with parameter values
    /// `params`.
    ///
    /// ```
    /// use dth_symbolic::{compile, Method};
    /// let h = compile("p1^2/2 + q1^4", &[]).unwrap();
    /// let (z0, z1) = ([1.0, 3.0], [2.0, 5.0]);
    /// let e = h.program(Method::DiscreteGradient).eval_pair(&z0, &z1, &[]).unwrap();
    /// // (2^4 - 1^4)/(2 - 1) = 15, (5^2 - 3^2)/2/(5 - 3) = 4; H(z1) - H(z0) = 15 + 8.
    /// assert_eq!(e.discrete_gradient, vec![15.0, 4.0]);
    /// assert_eq!(e.energy_difference, 23.0);
    /// ```
    pub fn eval_pair(
        &self,
        z0: &[f64],
        z1: &[f64],
        params: &[f64],
    ) -> Result<PairEvaluation, EvalError> {
        self.check_lengths(&[("z0", z0), ("z1", z1)], params)?;
        let v = self.run(z0, z1, params);
        let mut e = PairEvaluation {
            discrete_gradient: vec![0.0; self.dim],
            energy_difference: 0.0,
            discrete_gradient_defect: vec![0.0; self.dim],
        };
        for &(out, s) in &self.outputs {
            match out {
                Output::DiscreteGradient(i) => e.discrete_gradient[i] = v[s as usize],
                Output::EnergyDifference => e.energy_difference = v[s as usize],
                Output::DiscreteGradientDefect(i) => e.discrete_gradient_defect[i] = v[s as usize],
                _ => {}
            }
        }
        Ok(e)
    }

    /// `H(z)` in double-double arithmetic, rounded once to a double: the value a start's energy
    /// should have where it is a small difference of large terms (a regularized orbit's period
    /// follows it; see `dth_core::regularize`). Sums, products, quotients, square roots and
    /// integer and half-integer powers are carried to about 2^-106 of the terms, so the result
    /// is the double nearest `H(z)` for the program's constants unless `H` calls a function or
    /// a power with another exponent: those are evaluated in doubles at their argument rounded
    /// to a double (as [`Program::eval`] does), and their one rounding stays.
    ///
    /// ```
    /// use dth_symbolic::{compile, Method};
    /// // Kepler at pericentre, e = 0.999: |p|^2 - 1/r = 1.999 - 2, a difference of large terms.
    /// let h = compile("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[]).unwrap();
    /// let p = 1.999f64.sqrt();
    /// let z = [0.5, 0.0, 0.0, p];
    /// let value = h.program(Method::Value);
    /// // One rounding (1/r = 2 exactly): the plain sum loses the low bits of p^2.
    /// assert_eq!(value.value_double_double(&z, &[]).unwrap(), p.mul_add(p, -2.0));
    /// assert_ne!(value.eval(&z, &[]).unwrap().value, p.mul_add(p, -2.0));
    /// ```
    ///
    /// # Errors
    /// [`EvalError::WrongLength`] for `z` or `params` of the wrong length.
    pub fn value_double_double(&self, z: &[f64], params: &[f64]) -> Result<f64, EvalError> {
        Ok(self.value_in_double_double(z, params)?.to_f64())
    }

    /// [`Program::value_double_double`] before its rounding.
    ///
    /// # Errors
    /// As [`Program::value_double_double`].
    pub fn value_in_double_double(&self, z: &[f64], params: &[f64]) -> Result<Dd, EvalError> {
        self.check_lengths(&[("z", z)], params)?;
        let v = self.run_double_double(z, z, params);
        Ok(self
            .outputs
            .iter()
            .find(|(out, _)| *out == Output::Value)
            .map_or(Dd::new(0.0), |&(_, s)| v[s as usize]))
    }

    /// Every slot's value in double-double (see [`Program::value_double_double`]) at `z0` (and
    /// `z1`, the second point of a two-point program), for points and `params` of the program's
    /// lengths (it panics on shorter ones).
    pub fn run_double_double(&self, z0: &[f64], z1: &[f64], params: &[f64]) -> Vec<Dd> {
        let mut v = Vec::with_capacity(self.ops.len());
        self.run_double_double_into((|k| Dd::new(z0[k]), |k| Dd::new(z1[k])), params, &mut v);
        v
    }

    /// [`Program::run_double_double`] at points given entry by entry in double-double
    /// (`points.0(k)` is `z0[k]`, `points.1(k)` is `z1[k]`), into `v` (cleared; its capacity
    /// is kept, so a caller that keeps `v` allocates nothing per call).
    pub fn run_double_double_into(
        &self,
        points: (impl Fn(usize) -> Dd, impl Fn(usize) -> Dd),
        params: &[f64],
        v: &mut Vec<Dd>,
    ) {
        v.clear();
        for op in &self.ops {
            let g = |s: u32| v[s as usize];
            let x = match *op {
                Op::Input(k) => points.0(k as usize),
                Op::Input1(k) => points.1(k as usize),
                Op::Param(k) => Dd::new(params[k as usize]),
                Op::Const(c) => Dd::new(c),
                Op::Add(a, b) => g(a) + g(b),
                Op::Sub(a, b) => g(a) - g(b),
                Op::Mul(a, b) => g(a) * g(b),
                Op::Div(a, b) => g(a) / g(b),
                Op::Neg(a) => -g(a),
                Op::Sqrt(a) => g(a).sqrt(),
                Op::Powf(a, e) => g(a).powf(e),
                Op::Call(f, a) => Dd::new(f.apply(g(a).to_f64())),
                Op::Kernel(k, a, b) => Dd::new(k.apply(g(a).to_f64(), g(b).to_f64())),
            };
            v.push(x);
        }
    }

    /// `true` when [`Program::run_double_double`] carries every operation to about 2^-106
    /// (no function call, kernel or power other than an integer or half-integer one).
    pub fn exact_in_double_double(&self) -> bool {
        self.ops.iter().all(|op| match *op {
            Op::Call(..) | Op::Kernel(..) => false,
            Op::Powf(_, e) => Dd::exact_power(e).is_some(),
            _ => true,
        })
    }

    /// Each point `(name, z)` of length `D` and `params` of the declared number.
    fn check_lengths(
        &self,
        points: &[(&'static str, &[f64])],
        params: &[f64],
    ) -> Result<(), EvalError> {
        let lengths = points.iter().map(|&(what, z)| (what, self.dim, z.len()));
        for (what, expected, found) in lengths.chain([("params", self.params, params.len())]) {
            if found != expected {
                return Err(EvalError::WrongLength {
                    what,
                    expected,
                    found,
                });
            }
        }
        Ok(())
    }

    /// Every slot's value; lengths already checked.
    fn run(&self, z: &[f64], z1: &[f64], params: &[f64]) -> Vec<f64> {
        let mut v: Vec<f64> = Vec::with_capacity(self.ops.len());
        for op in &self.ops {
            let x = match *op {
                Op::Input(k) => z[k as usize],
                Op::Input1(k) => z1[k as usize],
                Op::Param(k) => params[k as usize],
                Op::Const(c) => c,
                Op::Add(a, b) => v[a as usize] + v[b as usize],
                Op::Sub(a, b) => v[a as usize] - v[b as usize],
                Op::Mul(a, b) => v[a as usize] * v[b as usize],
                Op::Div(a, b) => v[a as usize] / v[b as usize],
                Op::Neg(a) => -v[a as usize],
                Op::Sqrt(a) => v[a as usize].sqrt(),
                Op::Powf(a, e) => v[a as usize].powf(e),
                Op::Call(f, a) => f.apply(v[a as usize]),
                Op::Kernel(k, a, b) => k.apply(v[a as usize], v[b as usize]),
            };
            v.push(x);
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{compile, Method};

    /// Kepler's energy at the pericentre `q = (0.5, 0)` (`1/r = 2` exactly), `|p|^2 = 1 + e`
    /// rounded: `H = p^2 - 2` with one rounding is the fused `p.mul_add(p, -2)`, at every
    /// eccentricity, where the plain evaluation loses more of `E = e - 1` the nearer `e` is
    /// to 1.
    #[test]
    fn kepler_energy_at_pericentre_is_rounded_once() {
        let h = compile("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[]).unwrap();
        let value = h.program(Method::Value);
        let mut plain_misses = 0;
        for e in [0.44, 0.9, 0.99, 0.999, 0.9999, 0.99999, 0.999999] {
            let p = (1.0f64 + e).sqrt();
            let z = [0.5, 0.0, 0.0, p];
            let exact = p.mul_add(p, -2.0);
            assert_eq!(
                value.value_double_double(&z, &[]).unwrap(),
                exact,
                "e = {e}"
            );
            plain_misses += usize::from(value.eval(&z, &[]).unwrap().value != exact);
        }
        assert!(plain_misses >= 3, "{plain_misses}");
    }

    /// Integer and half-integer powers carried in double-double: `x^(3/2) x^(-3/2) = 1` and
    /// `x^5 = x x x x x` to about 2^-106.
    #[test]
    fn half_integer_powers_are_carried_exactly() {
        let x = Dd::new(1.0) / Dd::new(3.0);
        let one = x.powf(1.5) * x.powf(-1.5) - Dd::new(1.0);
        assert!(one.to_f64().abs() < 1e-30, "{one:?}");
        let five = x.powf(5.0) - x * x * x * x * x;
        assert!(five.to_f64().abs() < 1e-30 * x.powf(5.0).hi, "{five:?}");
        assert_eq!(Dd::exact_power(0.25), None);
        assert_eq!(Dd::new(2.0).powf(0.25).to_f64(), 2f64.powf(0.25));
    }

    /// A function is evaluated in doubles at its rounded argument: the value stays within a
    /// rounding of the terms of the plain one, and the program is not exact in double-double.
    #[test]
    fn functions_are_evaluated_in_doubles() {
        let h = compile("p1^2/2 - cos(q1)", &[]).unwrap();
        let value = h.program(Method::Value);
        let z = [0.7, 1.3];
        let plain = value.eval(&z, &[]).unwrap().value;
        let dd = value.value_double_double(&z, &[]).unwrap();
        assert!((dd - plain).abs() <= 2.0 * f64::EPSILON * (0.845 + 0.765));
        assert!(!value.exact_in_double_double());
        assert!(compile("p1^2 + q1^4", &[])
            .unwrap()
            .program(Method::Value)
            .exact_in_double_double());
        assert!(matches!(
            value.value_double_double(&[0.7], &[]),
            Err(EvalError::WrongLength { what: "z", .. })
        ));
    }
}
