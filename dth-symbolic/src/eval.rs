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

impl Program {
    /// Runs the program at `z` with parameter values `params`.
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
        let mut v: Vec<f64> = Vec::with_capacity(self.ops.len());
        for op in &self.ops {
            let x = match *op {
                Op::Input(k) => z[k as usize],
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
            };
            v.push(x);
        }
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
            }
        }
        Ok(e)
    }
}
