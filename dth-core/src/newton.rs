//! The Newton stopping rule ([`Convergence`]) and the Newton loop ([`solve`]) shared by the DTH
//! segment solvers (`dth::newton`) and the implicit peer methods (`methods::newton`).
//!
//! # Stopping rule
//! After each update the solver reports its size `u_i` relative to the state (the solver
//! chooses the measure: `|delta|_inf / |x|_inf` for the peers, the larger of the relative
//! changes of `z` and `lambda` for DTH). With the observed contraction
//! `theta_i = u_i / u_{i-1}`, the rule *signals a stop* after update `i` when
//! 1. `u_i <= tiny`: nothing is left to gain ([`Stop::Tiny`]); or
//! 2. `theta_i < 1` and the error left after the update, bounded as for a linear contraction
//!    by `u_i theta_i / (1 - theta_i)`, is at most `remainder`: further iterations cannot change
//!    the result beyond rounding (this ends a quadratically converging Newton: `u ~ 1e-16` after
//!    `1e-8` gives `theta ~ 1e-8`) ([`Stop::Settled`]); or
//! 3. `u_i <= stall` and the updates no longer halve (`theta_i > 1/2`, or `theta_i >= 1/2`
//!    where an exact halving counts as stalled): they have stopped shrinking below the stall
//!    tolerance, so what is left is the noise of evaluating the residual in floating point
//!    ([`Stop::Settled`]).
//!
//! Rules 2 and 3 need a previous update. A signalled stop is then
//! *gated* on the solver's residual at the iterate: if it passes, Newton has
//! [`Status::Converged`]; if not, it has [`Status::Diverged`] after rule 1 (there is nothing
//! left to gain) and continues after rules 2 and 3. Without a stop, Newton has
//! [`Status::Diverged`] at the iteration limit and continues below it. Updates that stop
//! shrinking above the stall tolerance are never accepted.
//!
//! # Parameters, and why the solvers differ
//! | | DTH segment ([`DTH`]) | implicit peers ([`PEERS`]) |
//! |---|---|---|
//! | `tiny` | `4 eps` | `0` |
//! | `remainder` | `4 eps` | `eps / 1024` |
//! | exact halving stalls | yes | no |
//! | `stall` | option `2^-40`, raised to the plain residual's noise | option `1024 eps` |
//! | gate | scaled residual below the residual tolerance | none |
//!
//! The DTH solvers accept nothing on the update size alone: every stop is gated on the scaled
//! residual, evaluated cancellation-free where the energy equation allows it, so stopping at a
//! `4 eps` update or a `4 eps` remainder costs no accuracy, and iterating further would only
//! chase the residual's roundoff floor (with the peers' parameters the thesis Kepler run takes
//! 4.09 joint iterations per step instead of 3.90). A quadratic remainder model `u theta^2`
//! would save an iteration per step but stops with a truncation error of about `1e-18` that is
//! systematic, not random: on the thesis Kepler run it drifted the vertex angular momentum to
//! `4.6e-14` over `10^4` steps, against `2.5e-15` with the linear bound.
//!
//! The peers have no residual gate and some of them (discrete gradient, discrete mechanics)
//! are quasi-Newton iterations converging linearly with a contraction of `O(dt^2)`. Stopping
//! them at a `4 eps` update leaves a remainder of a consistent sign, and the discrete-gradient
//! energy drifted linearly (`3.6e-17` per step on the thesis Kepler orbit, `3.6e-13` after
//! `10^4` steps); iterating to the noise floor (`tiny = 0`, `remainder = eps / 1024`) turns that
//! into a random walk (`3.5e-14` after `10^4` steps). Quadratic convergence still ends one
//! iteration early there, where its remainder estimate is reliable.
//!
//! An update of exactly half the previous one is common at the noise floor, where updates are a
//! few units in the last place. The gated DTH solvers stop there (the residual gate decides);
//! the ungated peers count it as still contracting and take one more update, in keeping with
//! iterating to the floor. (Changing either choice changes results in the last bits: on the
//! thesis Kepler orbit at `dt = 0.15` the discrete-gradient peer would take 13 fewer of its
//! 37,719 iterations over 5,000 steps, with different roundoff.)

/// When the rule lets Newton stop (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stop {
    /// Rule 1: the update is at most `tiny`; a residual above tolerance is then a failure.
    Tiny,
    /// Rules 2 and 3: the predicted remainder is negligible or the updates stalled at roundoff;
    /// a residual above tolerance means: keep iterating.
    Settled,
}

/// The verdict of [`Convergence::status`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Status {
    /// Stop with the current iterate.
    Converged,
    /// Stop with a failure: nothing left to gain, or the iteration limit.
    Diverged,
    /// Take another update.
    Continue,
}

/// The parameters of the stopping rule (see the [module docs](self) for why there are two sets).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rule {
    /// Updates at or below this relative size stop at once (rule 1).
    pub(crate) tiny: f64,
    /// Largest accepted predicted remainder, relative (rule 2).
    pub(crate) remainder: f64,
    /// Whether an update of exactly half the previous one counts as stalled (rule 3).
    pub(crate) exact_halving_stalls: bool,
}

/// The DTH segment solvers' rule: every stop is gated on the residual, so a few units in the
/// last place of update or remainder are enough.
pub(crate) const DTH: Rule = Rule {
    tiny: 4.0 * f64::EPSILON,
    remainder: 4.0 * f64::EPSILON,
    exact_halving_stalls: true,
};

/// The implicit peers' rule: no residual gate, and linearly converging iterations must reach
/// the noise floor (no stop on update size alone short of zero; remainder below 1/1024 ulp).
pub(crate) const PEERS: Rule = Rule {
    tiny: 0.0,
    remainder: f64::EPSILON / 1024.0,
    exact_halving_stalls: false,
};

/// The stopping rule applied to one Newton iteration: the rule's parameters, the iteration
/// limit and the last two relative update sizes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Convergence {
    rule: Rule,
    max_iterations: usize,
    iterations: usize,
    last: Option<f64>,
    previous: Option<f64>,
}

impl Convergence {
    /// Before the first update, with at most `max_iterations` updates.
    pub(crate) fn new(rule: Rule, max_iterations: usize) -> Self {
        Convergence {
            rule,
            max_iterations,
            iterations: 0,
            last: None,
            previous: None,
        }
    }

    /// Records an update of relative size `u`.
    pub(crate) fn push(&mut self, u: f64) {
        self.previous = self.last;
        self.last = Some(u);
        self.iterations += 1;
    }

    /// The number of updates so far.
    pub(crate) fn iterations(&self) -> usize {
        self.iterations
    }

    /// The relative size of the last update.
    pub(crate) fn last(&self) -> Option<f64> {
        self.last
    }

    /// Rules 1-3: whether Newton may stop at the current iterate, with stall tolerance `stall`.
    pub(crate) fn stop(&self, stall: f64) -> Option<Stop> {
        let u = self.last?;
        if u <= self.rule.tiny {
            return Some(Stop::Tiny);
        }
        let theta = u / self.previous?;
        if theta < 1.0 && u * theta / (1.0 - theta) <= self.rule.remainder {
            return Some(Stop::Settled);
        }
        let stalled = if self.rule.exact_halving_stalls {
            theta >= 0.5
        } else {
            theta > 0.5
        };
        if u <= stall && stalled {
            return Some(Stop::Settled);
        }
        None
    }

    /// The verdict for a signalled `stop` (or none) at the current iterate: `passes` evaluates
    /// the residual gate, and is called only when a stop is signalled.
    pub(crate) fn status(&self, stop: Option<Stop>, passes: impl FnOnce() -> bool) -> Status {
        if let Some(stop) = stop {
            if passes() {
                return Status::Converged;
            }
            if stop == Stop::Tiny {
                return Status::Diverged;
            }
        }
        if self.iterations >= self.max_iterations {
            Status::Diverged
        } else {
            Status::Continue
        }
    }

    /// [`stop`](Self::stop) and [`status`](Self::status) in one.
    pub(crate) fn check(&self, stall: f64, passes: impl FnOnce() -> bool) -> Status {
        self.status(self.stop(stall), passes)
    }
}

/// The Newton loop: check the rule, take an update, repeat.
///
/// `update` moves the iterate held in `state` by one Newton update (given its number, from 1)
/// and returns the update's relative size; `passes` is the residual gate at the current
/// iterate; `stall` the stall tolerance. Returns the number of updates at convergence, or the
/// error `diverged` makes from the state and that number.
pub(crate) fn solve<S, E>(
    mut convergence: Convergence,
    stall: f64,
    state: &mut S,
    mut update: impl FnMut(&mut S, usize) -> Result<f64, E>,
    passes: impl Fn(&S) -> bool,
    diverged: impl FnOnce(&mut S, usize) -> E,
) -> Result<usize, E> {
    loop {
        match convergence.check(stall, || passes(state)) {
            Status::Converged => return Ok(convergence.iterations()),
            Status::Diverged => return Err(diverged(state, convergence.iterations())),
            Status::Continue => {}
        }
        let u = update(state, convergence.iterations() + 1)?;
        convergence.push(u);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EPS: f64 = f64::EPSILON;

    fn after(rule: Rule, updates: &[f64]) -> Convergence {
        let mut c = Convergence::new(rule, 50);
        for &u in updates {
            c.push(u);
        }
        c
    }

    #[test]
    fn quadratic_convergence_stops_on_the_remainder() {
        // 1e-8 then 1e-16: theta = 1e-8, remainder ~1e-24.
        let c = after(PEERS, &[1e-8, 1e-16]);
        assert_eq!(c.stop(0.0), Some(Stop::Settled));
        assert_eq!(c.check(0.0, || true), Status::Converged);
        // One update is no contraction yet.
        assert_eq!(after(PEERS, &[1e-16]).stop(0.0), None);
    }

    #[test]
    fn linear_convergence_continues_until_the_noise_floor() {
        // theta = 0.1 at u = 1e-14: remainder 1.1e-15, above eps / 1024 (peers), above 4 eps
        // (DTH) too; below the stall tolerance but still shrinking.
        for rule in [PEERS, DTH] {
            let c = after(rule, &[1e-13, 1e-14]);
            assert_eq!(c.stop(1e-12), None);
            assert_eq!(c.check(1e-12, || true), Status::Continue);
        }
        // No longer halving below the stall tolerance: stalled; above it: go on.
        let c = after(PEERS, &[2e-14, 1.5e-14]);
        assert_eq!(c.stop(1e-12), Some(Stop::Settled));
        assert_eq!(c.stop(1e-15), None);
        // Exactly halved: stalled for DTH only.
        assert_eq!(after(DTH, &[2e-14, 1e-14]).stop(1e-12), Some(Stop::Settled));
        assert_eq!(after(PEERS, &[2e-14, 1e-14]).stop(1e-12), None);
    }

    #[test]
    fn tiny_updates_stop_at_once_for_dth_only() {
        assert_eq!(after(DTH, &[2.0 * EPS]).stop(0.0), Some(Stop::Tiny));
        assert_eq!(after(PEERS, &[2.0 * EPS]).stop(0.0), None);
        assert_eq!(after(PEERS, &[0.0]).stop(0.0), Some(Stop::Tiny));
    }

    #[test]
    fn the_gate_decides_and_a_failed_tiny_stop_diverges() {
        let tiny = after(DTH, &[1e-3, 2.0 * EPS]);
        assert_eq!(tiny.check(0.0, || false), Status::Diverged);
        let settled = after(DTH, &[1e-8, 1e-16 + 8.0 * EPS]);
        assert_eq!(settled.stop(0.0), Some(Stop::Settled));
        assert_eq!(settled.check(0.0, || false), Status::Continue);
        // The gate is not consulted without a stop.
        let going = after(DTH, &[1e-3]);
        assert_eq!(going.check(0.0, || panic!("gate called")), Status::Continue);
    }

    #[test]
    fn the_iteration_limit_diverges() {
        let mut c = Convergence::new(PEERS, 2);
        c.push(1.0);
        assert_eq!(c.check(0.0, || true), Status::Continue);
        c.push(0.9);
        assert_eq!(c.check(0.0, || true), Status::Diverged);
    }

    #[test]
    fn solve_counts_updates_and_reports_divergence() {
        // Halve x each update: linear, theta = 1/2; stalls once u <= stall.
        fn halve<E>(x: &mut f64, _: usize) -> Result<f64, E> {
            *x *= 0.5;
            Ok(*x)
        }
        let mut x = 1.0f64;
        let n = solve(
            Convergence::new(DTH, 50),
            1e-3,
            &mut x,
            halve::<()>,
            |_| true,
            |_, _| (),
        );
        // 2^-10 < 1e-3 < 2^-9: the 10th update is the first below the stall tolerance (and
        // exact halving counts as stalled with the DTH rule).
        assert_eq!(n, Ok(10));
        let mut x = 1.0f64;
        let err = solve(
            Convergence::new(PEERS, 5),
            1e-3,
            &mut x,
            halve,
            |_| true,
            |x, n| (*x, n),
        );
        assert_eq!(err, Err((1.0 / 32.0, 5)));
    }
}
