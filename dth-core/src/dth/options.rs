//! [`DthOptions`]: step size, initial multiplier and Newton settings, validated on construction.

use super::composition::Composition;
use crate::Error;

/// Which Newton iteration solves the step equations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Solver {
    /// One Newton iteration on `(zbar_{k+1}, lambda_{k+1})` jointly; the bordered Jacobian
    /// `[[A, -(h/2) J grad H], [grad H^T, 0]]` is solved by block elimination with two solves
    /// against `A = I - (h lambda / 2) J Hess H` (the default).
    #[default]
    Joint,
    /// The thesis's nested algorithm (Section 4.1): an inner Newton for `zbar_{k+1}` at fixed
    /// `lambda` (eq. 4.1.2) inside an outer Newton on `g(lambda) = H(z(h, lambda)) - H_0`
    /// (eq. 4.1.1).
    Nested,
}

impl Solver {
    /// Every solver, the default first.
    pub const ALL: [Solver; 2] = [Solver::Joint, Solver::Nested];

    /// Its name in scene files, tables and output (`"joint"`, `"nested"`).
    pub const fn name(self) -> &'static str {
        match self {
            Solver::Joint => "joint",
            Solver::Nested => "nested",
        }
    }

    /// The solver named `name` ([`Solver::name`]), if any.
    ///
    /// ```
    /// use dth_core::dth::Solver;
    /// assert_eq!(Solver::from_name("nested"), Some(Solver::Nested));
    /// assert_eq!(Solver::from_name("Nested"), None);
    /// ```
    pub fn from_name(name: &str) -> Option<Solver> {
        Solver::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// How the energy equation of a step is evaluated.
///
/// The plain residual `H(zbar_{k+1}) - H(zbar_0)` is a difference of `O(1)` numbers whose
/// solution-relevant part is `O(h^2)`: its roundoff puts an error of order `eps / h^2` into
/// `lambda` (relative; measured `3e-16` at `h = 0.06277`, `1e-12` at `1e-3`, `3e-9` at `1e-5` on
/// the thesis orbit). The cancellation-free residual solves `H(zbar_{k+1}) = H(zbar_k)` written
/// through an exact discrete gradient `gbar` and its trapezoid defect
/// `t = g_k + g_{k+1} - 2 gbar` (see [`Hamiltonian::discrete_gradient_defect`]):
///
/// ```text
/// H(zbar_{k+1}) - H(zbar_k) = (h/2) gbar^T J [lambda (g_{k+1} - gbar) + lambda_k (g_k - gbar)] + gbar . f
///   with lambda (g_{k+1} - gbar) + lambda_k (g_k - gbar)
///      = ((lambda - lambda_k)/2)(g_{k+1} - g_k) + ((lambda + lambda_k)/2) t,
/// ```
///
/// where `f` is the step equation's residual (zero at the solution; Newton eliminates it to
/// first order, so its roundoff does not enter `lambda`). Every term is then computed to a few
/// `eps` of its own `O(h^2)` size and `lambda` is accurate to a few `eps` for any `h`. Solving
/// against the previous midpoint alone would let the energy random-walk (`~eps sqrt(N)`), so
/// after convergence the midpoint is checked against `H(zbar_0)` with the plain residual (a
/// mismatch beyond the residual tolerance is [`Error::EnergyCheckFailed`]) and projected back
/// onto `H = H(zbar_0)` along `grad H` (a move of a few ulps, inside the roundoff of the step
/// equation; `lambda` is untouched). Energy at midpoints then stays bounded as with the plain
/// residual.
///
/// [`Hamiltonian::discrete_gradient_defect`]: crate::Hamiltonian::discrete_gradient_defect
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum EnergyResidual {
    /// [`EnergyResidual::CancellationFree`] when the Hamiltonian declares exact divided
    /// differences (`Flags::exact_divided_differences`), else
    /// [`EnergyResidual::Plain`] (with the default, plain-difference discrete gradient the
    /// cancellation-free form has the same `eps / h^2` noise and costs more). The default.
    #[default]
    Auto,
    /// `H(zbar_{k+1}) - H(zbar_0)` (paper eq. 30 as written). Cheapest; `lambda` noise
    /// `~eps / h^2`.
    Plain,
    /// The cancellation-free form above, then a check and projection against `H(zbar_0)`.
    /// Not available to [`segment_from_vertex`](super::segment_from_vertex), which has no
    /// previous midpoint (it uses [`EnergyResidual::Plain`]).
    CancellationFree,
}

/// Options of the DTH stepper. Build with [`DthOptions::new`] (the step `dtau`, which has no
/// default) and the `with_*` methods.
///
/// **Which setters need `?`.** A setter that takes a number (`with_dtau`, `with_lambda0`,
/// `with_max_iterations`, `with_residual_tolerance`, `with_stall_tolerance`,
/// `with_max_lambda_ratio`, `with_order`) checks it and returns `Result<Self, Error>`
/// ([`Error::InvalidOption`] named after the option): follow it with `?`. A setter that takes
/// a type whose every value is valid (`with_solver`, `with_energy_residual`, `with_robust`,
/// `with_composition`: an enum or a `bool`) cannot fail and returns `Self`. The same rule
/// holds for the peers' [`NewtonOptions`](crate::methods::NewtonOptions) and
/// [`Dth::with_tbar0`](super::Dth::with_tbar0).
///
/// ```
/// use dth_core::dth::{DthOptions, Solver};
/// let options = DthOptions::thesis_kepler()
///     .with_dtau(0.06277)?
///     .with_lambda0(1.0)?
///     .with_solver(Solver::Nested)
///     .with_robust(true)
///     .with_order(4)?;
/// assert_eq!(options.dtau(), 0.06277);
/// assert!(DthOptions::new(-1.0).is_err());
/// # Ok::<(), dth_core::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct DthOptions {
    dtau: f64,
    lambda0: f64,
    solver: Solver,
    max_iterations: u32,
    residual_tolerance: f64,
    stall_tolerance: f64,
    energy_residual: EnergyResidual,
    max_lambda_ratio: f64,
    robust: bool,
    composition: Composition,
}

impl DthOptions {
    /// Options with the step `dtau` in the parameter `tau` (`h`; positive and finite) and the
    /// defaults for the rest: `lambda0 = 1` (the thesis's choice), joint Newton, at most 50
    /// iterations, residual tolerance `64 eps`, stall tolerance `2^-40`,
    /// [`EnergyResidual::Auto`], breakdown at a predicted `lambda` ratio of 8, robust mode
    /// off, order 2 ([`Composition::Order2`]).
    ///
    /// There is no default `dtau`: the right one depends on the system's time scale (the
    /// physical step is `dt = lambda dtau`, and `lambda_0 = 1`). A step of about a twentieth
    /// of the shortest period the run should resolve is a start; the run's energy is exact
    /// at every `dtau`, its orbit error is `O(dtau^2)` (order 2).
    ///
    /// # Errors
    /// [`Error::InvalidOption`] (`dtau`) when `dtau` is not positive and finite.
    pub fn new(dtau: f64) -> Result<Self, Error> {
        Ok(DthOptions {
            dtau: positive_finite("dtau", dtau)?,
            ..Self::thesis_kepler()
        })
    }

    /// The thesis's settings for its Kepler problem (Table 4.1: `dtau = 0.06277`, 25 points
    /// per orbit of the `e = 0.44` orbit of [`Kepler::thesis`](crate::systems::Kepler::thesis)
    /// from `(0.5, 0, 0, 1.2)`), the rest as [`DthOptions::new`]. A preset for that system,
    /// not a default for others.
    pub fn thesis_kepler() -> Self {
        DthOptions {
            dtau: 0.06277,
            lambda0: 1.0,
            solver: Solver::Joint,
            max_iterations: 50,
            residual_tolerance: 64.0 * f64::EPSILON,
            stall_tolerance: 2f64.powi(-40),
            energy_residual: EnergyResidual::Auto,
            max_lambda_ratio: 8.0,
            robust: false,
            composition: Composition::Order2,
        }
    }
}

fn positive_finite(name: &'static str, value: f64) -> Result<f64, Error> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(Error::InvalidOption {
            name,
            value,
            reason: "must be positive and finite",
        })
    }
}

impl DthOptions {
    /// The fixed step `dtau` (`h`) in the parameter `tau` (set first by [`DthOptions::new`]).
    /// Must be positive and finite.
    pub fn with_dtau(mut self, dtau: f64) -> Result<Self, Error> {
        self.dtau = positive_finite("dtau", dtau)?;
        Ok(self)
    }

    /// The multiplier `lambda_0 = dt/dtau` of the first segment. Default `1` (the thesis's
    /// choice). Must be positive and finite.
    pub fn with_lambda0(mut self, lambda0: f64) -> Result<Self, Error> {
        self.lambda0 = positive_finite("lambda0", lambda0)?;
        Ok(self)
    }

    /// The Newton variant. Default [`Solver::Joint`].
    pub fn with_solver(mut self, solver: Solver) -> Self {
        self.solver = solver;
        self
    }

    /// Maximum Newton iterations per step (outer iterations for [`Solver::Nested`], which uses
    /// the same limit for each inner solve). Default 50. Must be at least 1.
    pub fn with_max_iterations(mut self, max_iterations: u32) -> Result<Self, Error> {
        if max_iterations == 0 {
            return Err(Error::InvalidOption {
                name: "max_iterations",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        self.max_iterations = max_iterations;
        Ok(self)
    }

    /// Largest accepted scaled residual at convergence: each equation's residual divided by the
    /// magnitude of its terms (`|z|`, `|H|`, `sum |z_i dH/dz_i|`), so roundoff gives a few `eps`.
    /// Default `64 eps` (about `1.4e-14`). Must lie in `[eps, 1)`.
    pub fn with_residual_tolerance(mut self, tolerance: f64) -> Result<Self, Error> {
        if !(f64::EPSILON..1.0).contains(&tolerance) {
            return Err(Error::InvalidOption {
                name: "residual_tolerance",
                value: tolerance,
                reason: "must lie in [f64::EPSILON, 1)",
            });
        }
        self.residual_tolerance = tolerance;
        Ok(self)
    }

    /// Relative update size below which an update that no longer halves counts as stalled at
    /// roundoff (Newton then stops; the residual must still pass
    /// [`with_residual_tolerance`](Self::with_residual_tolerance) or the step fails). Updates
    /// below `4 eps` always stop. Default `2^-40` (about `9.1e-13`). Must lie in `[eps, 1)`.
    pub fn with_stall_tolerance(mut self, tolerance: f64) -> Result<Self, Error> {
        if !(f64::EPSILON..1.0).contains(&tolerance) {
            return Err(Error::InvalidOption {
                name: "stall_tolerance",
                value: tolerance,
                reason: "must lie in [f64::EPSILON, 1)",
            });
        }
        self.stall_tolerance = tolerance;
        Ok(self)
    }

    /// How the energy equation is evaluated. Default [`EnergyResidual::Auto`].
    pub fn with_energy_residual(mut self, energy_residual: EnergyResidual) -> Self {
        self.energy_residual = energy_residual;
        self
    }

    /// The energy residual form.
    pub fn energy_residual(&self) -> EnergyResidual {
        self.energy_residual
    }

    /// Breakdown detection: before Newton, `lambda_{k+1}` is predicted from the law of time
    /// (`lambda Psi^(1/3)` constant, paper Theorem 5) with `Psi` at an explicit predictor of
    /// `zbar_{k+1}`. When `Psi` changes sign there, or the predicted `lambda_{k+1} / lambda_k`
    /// exceeds this ratio (and again if Newton's root does), the step has no usable positive
    /// root: the step fails with [`Error::Breakdown`] (or, in robust mode, a fallback step is
    /// taken). Default 8: on smooth orbits the ratio stays near 1 (at most 1.30 on Kepler
    /// e = 0.7 at 25 points per orbit). Must be finite and greater than 1.
    pub fn with_max_lambda_ratio(mut self, ratio: f64) -> Result<Self, Error> {
        if !(ratio.is_finite() && ratio > 1.0) {
            return Err(Error::InvalidOption {
                name: "max_lambda_ratio",
                value: ratio,
                reason: "must be finite and greater than 1",
            });
        }
        self.max_lambda_ratio = ratio;
        Ok(self)
    }

    /// Robust mode (opt-in, default off): the run goes through the places where DTH itself
    /// has no positive root, where `Psi = (J grad H)^T Hess H (J grad H)` changes sign (Kepler
    /// above e ~ 0.79, the pendulum in rotation, driven systems, close encounters).
    ///
    /// - **Where DTH runs.** DTH's step has a root wherever `Psi` does not vanish, of either
    ///   sign; near a sign change the law of time `lambda^3 |Psi| = const` (paper Theorem 5)
    ///   sends the physical step to infinity. So the robust mode measures how much the terms
    ///   of `Psi = sum_ij v_i H_ij v_j` (`v = J grad H`, `H_ij` the Hessian) cancel,
    ///   `|Psi| / sum_ij |v_i H_ij v_j|` (independent of the units of `q` and `p`),
    ///   and leaves DTH where that ratio falls below 6.5% (5% at order 4-8), resuming where it
    ///   is back above 10%,
    ///   on either side of the sign change, with the `lambda` of the run's law of time. A DTH
    ///   step that breaks down or whose Newton fails ([`Error::Breakdown`],
    ///   [`Error::NewtonDiverged`], [`Error::SpuriousRoot`], [`Error::SingularMatrix`],
    ///   [`Error::NonFinite`] at a Newton iterate) is redone as a fallback step too.
    /// - **Fallback steps** are energy-conserving discrete-gradient steps in `(q, p)`
    ///   ([`methods::DiscreteGradient`](crate::methods::DiscreteGradient), with the Hamiltonian's
    ///   exact divided differences where it has them), with energy checked and projected
    ///   against `H(zbar_0)` (along `grad H`, then, where the positions' rounding leaves more,
    ///   as at a close encounter, along the momenta alone: `H` stays at the roundoff of its
    ///   terms), marked [`StepKind::Fallback`](crate::observer::StepKind::Fallback). A solve
    ///   whose residual fails the plain check is kept when the Newton correction it implies is
    ///   below the tolerance (the residual of a converged step near a collision is the
    ///   positions' rounding amplified by `dt |Hess H|`).
    ///   Their physical size is a function of the state and `dtau` only: DTH's own law of
    ///   time `dtau (law / |Psi|)^(1/3)` (`law = lambda_0^3 |Psi_0|`) where the ratio is at
    ///   least 10%, below that its value at 10% times a factor going linearly from 1 there to
    ///   0.3 where `Psi` changes sign: continuous where DTH resumes, bounded inside the band,
    ///   so both kinds of step shrink with `dtau` and the run converges at second order. Where a
    ///   fallback step's Newton fails, the step is halved, down to `2^-20` of that size; below
    ///   that (or on a non-finite `H`, or a failed energy check) the run stops with that error.
    /// - **Order 4-8** ([`with_order`](Self::with_order)): a composed step is all DTH steps or
    ///   all fallback steps, composed with the same coefficients (the discrete-gradient step is
    ///   symmetric, so the composition has the order asked for); a composed DTH step that
    ///   fails, or any of whose midpoints reaches into a band (ratio below 5%), is redone from
    ///   its start as fallback steps.
    ///
    /// Where the ratio stays above 6.5% (5% at order 4-8) and no step fails, the run is
    /// bit-identical to one without robust mode. The vertex invariants of DTH (paper Theorem 7)
    /// do not hold across fallback steps (a fallback node is its own vertex).
    pub fn with_robust(mut self, robust: bool) -> Self {
        self.robust = robust;
        self
    }

    /// The order of the method: 2 (plain DTH, the default), 4, 6 or 8, by symmetric
    /// composition of DTH steps in `tau` ([`Composition`]: Suzuki's five-stage composition
    /// for 4, Kahan and Li's nine- and seventeen-stage ones for 6 and 8). Each step of size
    /// `dtau` is then `s` DTH steps of sizes `gamma_i dtau`, some of them negative (they run
    /// backwards in time, with `lambda > 0`); energy stays exact at every midpoint, and a
    /// step costs about `s` plain DTH steps. See [`Composition`] for what is lost above order
    /// 2 (the exact vertex invariants).
    ///
    /// ```
    /// use dth_core::dth::{Composition, DthOptions};
    /// let options = DthOptions::thesis_kepler().with_order(8)?;
    /// assert_eq!(options.composition(), Composition::KahanLi8);
    /// assert!(DthOptions::thesis_kepler().with_order(3).is_err());
    /// # Ok::<(), dth_core::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::InvalidOption`] (`order`) for anything but 2, 4, 6, 8.
    pub fn with_order(self, order: u32) -> Result<Self, Error> {
        match Composition::from_order(order) {
            Some(c) => Ok(self.with_composition(c)),
            None => Err(Error::InvalidOption {
                name: "order",
                value: f64::from(order),
                reason: "must be 2, 4, 6 or 8",
            }),
        }
    }

    /// The composition directly (the same as [`with_order`](Self::with_order) with its order).
    pub fn with_composition(mut self, composition: Composition) -> Self {
        self.composition = composition;
        self
    }

    /// The composition (order 2: [`Composition::Order2`]).
    pub fn composition(&self) -> Composition {
        self.composition
    }

    /// The order: 2, 4, 6 or 8.
    pub fn order(&self) -> u32 {
        self.composition.order()
    }

    /// The breakdown ratio for predicted `lambda_{k+1} / lambda_k`.
    pub fn max_lambda_ratio(&self) -> f64 {
        self.max_lambda_ratio
    }
    /// `true` in robust mode.
    pub fn robust(&self) -> bool {
        self.robust
    }
    /// `dtau`.
    pub fn dtau(&self) -> f64 {
        self.dtau
    }
    /// `lambda_0`.
    pub fn lambda0(&self) -> f64 {
        self.lambda0
    }
    /// The Newton variant.
    pub fn solver(&self) -> Solver {
        self.solver
    }
    /// Maximum Newton iterations per step.
    pub fn max_iterations(&self) -> u32 {
        self.max_iterations
    }
    /// Residual tolerance (scaled, dimensionless).
    pub fn residual_tolerance(&self) -> f64 {
        self.residual_tolerance
    }
    /// Stall tolerance (relative update).
    pub fn stall_tolerance(&self) -> f64 {
        self.stall_tolerance
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_non_positive_and_non_finite() {
        let o = DthOptions::thesis_kepler();
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                o.with_dtau(bad),
                Err(Error::InvalidOption { name: "dtau", .. })
            ));
            assert!(matches!(
                o.with_lambda0(bad),
                Err(Error::InvalidOption {
                    name: "lambda0",
                    ..
                })
            ));
        }
        assert!(matches!(
            o.with_max_iterations(0),
            Err(Error::InvalidOption {
                name: "max_iterations",
                ..
            })
        ));
        assert!(o.with_residual_tolerance(0.0).is_err());
        assert!(o.with_stall_tolerance(1.0).is_err());
        assert_eq!(o.with_dtau(0.1).map(|o| o.dtau()), Ok(0.1));
    }
}
