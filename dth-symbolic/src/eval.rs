//! The interpreter: runs a [`Program`] on `f64`s. It tests the engine without a compiler and
//! is the run-time path for Hamiltonians read from text.

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
        if z.len() != self.dim {
            return Err(EvalError::WrongLength {
                what: "z",
                expected: self.dim,
                found: z.len(),
            });
        }
        if params.len() != self.params {
            return Err(EvalError::WrongLength {
                what: "params",
                expected: self.params,
                found: params.len(),
            });
        }
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
        for (what, z) in [("z0", z0), ("z1", z1)] {
            if z.len() != self.dim {
                return Err(EvalError::WrongLength {
                    what,
                    expected: self.dim,
                    found: z.len(),
                });
            }
        }
        if params.len() != self.params {
            return Err(EvalError::WrongLength {
                what: "params",
                expected: self.params,
                found: params.len(),
            });
        }
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
