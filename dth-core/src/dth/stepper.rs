//! The DTH stepper [`Dth`] and the one-call [`integrate`].

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::compensated::Compensated;
use super::linear::{self, Dense, Linear, Point};
use super::newton::{add_j_times, all_finite, Work};
use super::newton::{predict_into, project, roundoff_scale, solve_segment, Anchor, Previous};
use super::options::DthOptions;
use super::options::EnergyResidual;
use super::robust::{self, fallback_step, FallbackWork, Mode, ScaleWork};
use super::trajectory::Trajectory;
use crate::error::RunError;
use crate::linalg::two_sum;
use crate::methods::{check_state, Structured};
use crate::observer::{DthRecord, Observer, StepKind, StepRecord};
use crate::{j_times, zeros, Error, Flags, Hamiltonian};

/// The autonomous DTH stepper (paper Corollary 1, eqs. 28-30), monomorphized over the
/// Hamiltonian: no `dyn`, no heap allocation per step. Its workspace (the Newton iterate and
/// evaluation, the predictor's and the robust mode's vectors, the record it reports) is
/// allocated in [`Dth::new`], the dense linear algebra on the first step; after that,
/// [`Dth::run`] and [`Dth::advance`] allocate nothing, for a `Dyn` dimension too (the records
/// they report are borrowed; [`Dth::step`] returns an owned copy, two heap allocations for
/// `Dyn`: the state and the vertex). To step one at a time without allocating, call
/// `advance(1)` and read the step's record with [`Dth::record_ref`]. A clone keeps the
/// workspace (it steps without allocating too).
///
/// State: midpoint `zbar_k`, multiplier `lambda_k`, midpoint time `tbar_k`. A step finds
/// `zbar_{k+1}` and `lambda_{k+1} > 0` with
///
/// ```text
/// zbar_{k+1} - zbar_k = (h/2) J [lambda_{k+1} gradH(zbar_{k+1}) + lambda_k gradH(zbar_k)],
/// H(zbar_{k+1}) = H(zbar_0),
/// ```
///
/// and `tbar_{k+1} = tbar_k + h (lambda_{k+1} + lambda_k) / 2`. Vertices:
/// `z^(k) = zbar_k - (h/2) zbar'_k`, `z^(k+1) = zbar_k + (h/2) zbar'_k` with the slope
/// `zbar'_k = lambda_k J gradH(zbar_k)`; vertex times `t^(k) = tbar_k - h lambda_k / 2`.
///
/// A time-dependent Hamiltonian (`flags().time_dependent`) lives in the extended phase space
/// (paper Theorem 1, eqs. 9-11) with `calH(zbar_0) = 0`; there `tbar_0` is read from the `t`
/// coordinate `zbar_0[D/2 - 1]`.
///
/// ```
/// use dth_core::dth::{Dth, DthOptions};
/// use dth_core::nalgebra::Vector4;
/// use dth_core::systems::Kepler;
///
/// let kepler = Kepler::thesis();
/// let zbar0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
/// let mut dth = Dth::new(kepler, zbar0, DthOptions::thesis_kepler())?;
/// let trajectory = dth.trajectory(100)?;
/// assert_eq!(trajectory.len(), 101); // zbar_0 .. zbar_100
/// assert_eq!(trajectory.vertices().len(), 102);
/// // Energy at the midpoints is exact to roundoff (Theorem 4).
/// let e0 = -0.56;
/// for zbar in trajectory.midpoints() {
///     assert!((dth_core::Hamiltonian::value(&kepler, zbar) - e0).abs() < 1e-14);
/// }
/// // Keep going with an observer that stores nothing.
/// dth.run(100, &mut ())?;
/// assert_eq!(dth.k(), 200);
/// # Ok::<(), dth_core::Error>(())
/// ```
///
/// # References
/// Shibberu (1998), Corollary 1 (eqs. 28-30), Theorem 1 (eqs. 9-11); thesis eqs. 2.2.3-2.2.5,
/// 2.3.1-2.3.7, Section 4.1.
#[derive(Clone, Debug)]
pub struct Dth<H, D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    hamiltonian: H,
    /// `H`'s flags, read once in [`Dth::new`].
    flags: Flags,
    options: DthOptions,
    /// The level every midpoint is solved against.
    energy: f64,
    /// Everything a step changes (restored as a whole when a composed step fails part-way).
    s: State<D>,
    /// The structured Newton matrix when `H` takes that path (see `dth::linear`): analysed
    /// once, in [`Dth::new`], and reused by every step without allocation. A cache, not state.
    newton: Structured,
    /// Everything a step writes besides its state (on the heap, so that a stepper of any size
    /// moves cheaply). Scratch, not state.
    work: Box<Workspace<D>>,
}

/// The storage a step works in, built once in [`Dth::new`].
#[derive(Clone, Debug)]
struct Workspace<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// The segment solve: the predictor goes into `newton.z`, the solution comes out there.
    newton: Work<D>,
    /// The dense path's storage (`None` on the structured path).
    dense: Option<Box<Dense<D>>>,
    /// The left vertex of the new segment.
    v: OVector<f64, D>,
    /// Scratch of the predictor's fixed-point sweeps (`g`, `z1`), and `z1` itself.
    g: OVector<f64, D>,
    sweep: OVector<f64, D>,
    z1: OVector<f64, D>,
    /// `H` at a predicted midpoint.
    point: Point<D>,
    /// The state at the start of a composed step, restored when it fails.
    saved: State<D>,
    /// The record of the current midpoint, as reported.
    record: StepRecord<D>,
    /// The record at the start of a composed step, restored with `saved` (a step's record is
    /// written when the step is made: a fallback step's before the robust mode's resume
    /// changes the state's `lambda` and kind, so it cannot be rebuilt from the state).
    saved_record: StepRecord<D>,
    /// The robust mode's fallback steps, and the walk of [`Dth::diagnose`].
    fallback: FallbackWork<D>,
    walk: OVector<f64, D>,
    /// Scratch of `Psi_scale` (robust mode).
    scale: ScaleWork<D>,
}

/// The state of a [`Dth`] stepper that steps change.
#[derive(Clone, Debug)]
struct State<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    k: usize,
    zbar: OVector<f64, D>,
    lambda: f64,
    tbar: f64,
    gradient: OVector<f64, D>,
    psi: f64,
    iterations: u32,
    factorizations: u32,
    reported: bool,
    /// `Psi_scale` at `zbar` (robust mode; 0 otherwise): see `dth::robust`.
    psi_scale: f64,
    /// What the next step is (always [`Mode::Dth`] without the robust mode).
    mode: Mode,
    /// What produced the current midpoint, as its record says: [`StepKind::Fallback`] if any
    /// sub-step of the last step was one.
    step_kind: StepKind,
    /// The robust mode's law of time (`lambda^3 |Psi|` where `Psi` does not cancel, see
    /// `dth::robust`), set at the first midpoint where it is positive (0 before). It sizes the
    /// fallback steps and gives DTH its `lambda` where it resumes, so that the resolution the
    /// user chose with `lambda_0` is kept across fallback stretches.
    law: f64,
    /// Signed step in `tau` of the segment of the current midpoint: both its halves
    /// (`gamma_1 dtau` for a composed step, `gamma_1 = gamma_s`; `dtau` at order 2). The
    /// vertices of the current segment are `zbar -+ (h_edge/2) zbar'`.
    h_edge: f64,
    /// The roundoff noise of the last step's time advance from the noise of its `lambda`s
    /// (plain energy residual: `sum |h_i| lambda_i noise_i` over its DTH sub-steps).
    time_noise: f64,
    /// The index of the `t` coordinate when it is the physical time and the flow's parameter
    /// a fictitious one (`Flags::regularized`): midpoint and vertex times are then read from
    /// it. `None`: the time is the sum of the steps' `h lambda`.
    clock: Option<usize>,
    /// The low part of the midpoint of a regularized run (where `clock` is set): see
    /// `dth::compensated`.
    compensated: Option<Compensated<D>>,
}

impl<D: Dim> State<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// The low part of the midpoint time where the run is solved in double-double (its time
    /// is `tbar` plus this), else 0.
    fn clock_low(&self) -> f64 {
        match (self.clock, &self.compensated) {
            (Some(i), Some(c)) if c.double_double() => c.low()[i],
            _ => 0.0,
        }
    }

    /// Make this a copy of `other`, in its own storage (`clone_from` would allocate for `Dyn`).
    fn assign(&mut self, other: &Self) {
        let State {
            k,
            zbar,
            lambda,
            tbar,
            gradient,
            psi,
            iterations,
            factorizations,
            reported,
            psi_scale,
            mode,
            step_kind,
            law,
            h_edge,
            time_noise,
            clock,
            compensated,
        } = other;
        self.zbar.copy_from(zbar);
        self.gradient.copy_from(gradient);
        (self.k, self.lambda, self.tbar, self.psi) = (*k, *lambda, *tbar, *psi);
        (self.iterations, self.factorizations) = (*iterations, *factorizations);
        (self.reported, self.psi_scale, self.mode, self.step_kind) =
            (*reported, *psi_scale, *mode, *step_kind);
        (self.law, self.h_edge, self.time_noise) = (*law, *h_edge, *time_noise);
        self.clock = *clock;
        match (&mut self.compensated, compensated) {
            (Some(mine), Some(theirs)) => mine.assign(theirs),
            (mine, theirs) => mine.clone_from(theirs),
        }
    }
}

/// Fixed-point sweeps that refine Newton's start once `lambda` is predicted (see
/// [`refine_start`]).
const START_SWEEPS: usize = 2;

/// The contraction each of those sweeps must show to be kept: a change at most this fraction
/// of the one before. Where `lambda` is steady the sweeps contract by 0.01-0.17 (regularized
/// and plain Kepler); a weaker contraction means a step so large (`c |J Hess H|` near 1) that
/// the fixed point of the predicted `lambda` is no better a start than the third sweep. On
/// Henon-Heiles at the saddle energy, where `lambda` doubles from step to step towards the
/// saddle, sweeps kept at a contraction of 0.5 started Newton where it converged to a root with
/// `lambda < 0`.
const START_CONTRACTION: f64 = 0.125;

/// Predicted growth of `lambda` in one step beyond which breakdown detection looks a second time,
/// at the predictor for the predicted `lambda` (on smooth orbits the ratio stays below ~1.2 at
/// 25 points per orbit; it grows without bound as `Psi -> 0`).
const LOOK_AGAIN: f64 = 1.25;

/// Largest relative energy error of a predicted midpoint whose `Psi` is trusted for breakdown
/// detection (the predictor's error is `O(h^3)`: about 1e-4 at the thesis's step).
const PREDICTOR_TRUST: f64 = 1e-2;

/// How many orbit steps [`Dth::diagnose`] looks ahead for a sign change of `Psi`.
const DIAGNOSE_STEPS: usize = 3;

/// A robust-mode fallback step halves its `dt` (from the size the law of time gives) down to
/// `2^-MAX_FALLBACK_HALVINGS` of it before giving up: where its Newton fails (a step too large
/// near a close approach).
const MAX_FALLBACK_HALVINGS: u32 = 20;

/// Tries of [`Dth::step_toward`]'s last step at most: the secant converges in three or four
/// where the midpoint time is nearly linear in the step; where it is not (a regularized `K`,
/// whose physical time per step follows `|u|^2`, at a few steps per orbit) bisection of the
/// bracket takes over, which halves it per try (from the whole step to roundoff in about 50).
const MAX_END_ITERATIONS: usize = 64;

/// [`Dth::step_toward`] lands its last midpoint within `END_TOLERANCE eps max(|t_end|, |t_0|)`
/// of `t_end`: the time sum `tbar_k + h (lambda_k + lambda_{k+1})/2` rounds by about
/// `eps |t|` per addition, and the secant's last iterate carries that of its two brackets.
const END_TOLERANCE: f64 = 4.0;

/// The rounding of a time sum between `t0` and `t_end`: `END_TOLERANCE eps` of the larger.
fn end_tolerance(t0: f64, t_end: f64) -> f64 {
    END_TOLERANCE * f64::EPSILON * t_end.abs().max(t0.abs())
}

/// What [`Dth::step_toward`]'s last step scales to land on `t_end`.
#[derive(Clone, Copy, Debug)]
enum End {
    /// The run's composed step, by its `dtau`.
    Step,
    /// Fallback steps (robust mode), by their physical size.
    Fallback,
}

/// Where [`Dth::step_toward`]'s last step must land.
#[derive(Clone, Copy, Debug)]
struct Landing {
    t0: f64,
    t_end: f64,
    /// Where the iteration stops: the acceptance tolerance of the landing, or for a run
    /// solved in double-double (whose time is smooth in the step far below its rounding)
    /// `END_TOLERANCE eps` of the full step's time, what the scale of the step (a double)
    /// resolves.
    target: f64,
}

/// The try of [`Dth::step_toward`]'s last step closest to `t_end` so far.
struct Best<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// `|tbar - t_end|`.
    gap: f64,
    state: State<D>,
    record: StepRecord<D>,
}

impl<D: Dim> Best<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Keep the try that ended `f = tbar - t_end` away if it is closer.
    fn offer(&mut self, f: f64, state: &State<D>, record: &StepRecord<D>) {
        if f.abs() < self.gap {
            self.gap = f.abs();
            self.state.assign(state);
            self.record.copy_from(record);
        }
    }
}

/// The Newton work of one composed step, over all its tries, and the physical size of its
/// fallback steps (when it is one).
#[derive(Clone, Copy, Debug, Default)]
struct Spent {
    iterations: u32,
    factorizations: u32,
    fallback_dt: f64,
    /// See `State::time_noise`.
    time_noise: f64,
}

impl Spent {
    fn add(&mut self, iterations: u32, factorizations: u32) {
        self.iterations = self.iterations.saturating_add(iterations);
        self.factorizations = self.factorizations.saturating_add(factorizations);
    }
}

/// The failures of a DTH step that the robust mode carries through with fallback steps: the
/// method's breakdown, and Newton failures (a non-finite value inside Newton means it wandered,
/// into a singularity of `H`, say: the fallback step re-evaluates from the accepted midpoint and
/// stops the run if `H` itself is the problem).
fn recoverable(error: &Error) -> bool {
    matches!(
        error,
        Error::Breakdown { .. }
            | Error::NewtonDiverged { .. }
            | Error::SpuriousRoot { .. }
            | Error::SingularMatrix { .. }
            | Error::NonFinite { .. }
    )
}

impl<H: Hamiltonian<D>, D: Dim> Dth<H, D>
where
    DefaultAllocator: Alloc<D>,
{
    /// A stepper at the initial midpoint `zbar_0` with `lambda_0 = options.lambda0()` and
    /// `tbar_0 = 0` (extended phase space: `tbar_0 = zbar_0[D/2 - 1]`).
    ///
    /// Hamiltonians with [`Flags::psi_identically_zero`] are rejected: DTH is undetermined
    /// for them.
    ///
    /// ```
    /// use dth_core::{dth::{Dth, DthOptions}, Error, Flags, Hamiltonian};
    /// use dth_core::nalgebra::{Const, Matrix2, Vector2};
    /// struct Linear;
    /// impl Hamiltonian<Const<2>> for Linear {
    ///     fn dim(&self) -> Const<2> { Const }
    ///     fn flags(&self) -> Flags { Flags::default().with_psi_identically_zero(true) }
    ///     fn value(&self, z: &Vector2<f64>) -> f64 { z[0] + z[1] }
    ///     fn gradient_into(&self, _: &Vector2<f64>, out: &mut Vector2<f64>) {
    ///         *out = Vector2::new(1.0, 1.0);
    ///     }
    ///     fn hessian_into(&self, _: &Vector2<f64>, out: &mut Matrix2<f64>) { out.fill(0.0) }
    /// }
    /// let err = Dth::new(Linear, Vector2::new(0.0, 1.0), DthOptions::new(0.1)?).err().unwrap();
    /// assert!(matches!(err, Error::PsiIdenticallyZero));
    /// # Ok::<(), Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::PsiIdenticallyZero`] as above; [`Error::OddDimension`] for a phase space of
    /// odd dimension; [`Error::WrongStateLength`] (`zbar0`) when `zbar_0`'s length is not
    /// `H`'s dimension; [`Error::NonFiniteInitialState`] for a NaN or infinite component of
    /// `zbar_0`;
    /// [`Error::NonFinite`] (step 0) when `H`, its gradient or Hessian is not finite there;
    /// [`Error::ExtendedEnergyNotZero`] for a time-dependent `H` with `calH(zbar_0) != 0`.
    pub fn new(hamiltonian: H, zbar0: OVector<f64, D>, options: DthOptions) -> Result<Self, Error> {
        let flags = hamiltonian.flags();
        if flags.psi_identically_zero {
            return Err(Error::PsiIdenticallyZero);
        }
        check_state(&hamiltonian, &zbar0, "zbar0")?;
        if let Some((index, &value)) = zbar0.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(Error::NonFiniteInitialState { index, value });
        }
        let mut newton = Structured::default();
        let dim = hamiltonian.dim();
        let mut dense = None;
        let mut d = Point::zeros(dim);
        let mut scale = ScaleWork::new(dim);
        let mut path = linear::path(&hamiltonian, &mut newton, &mut dense);
        path.evaluate(&hamiltonian, &zbar0, &mut d);
        let psi_scale = if options.robust() {
            robust::psi_scale(&path, &d.gradient, &mut scale)
        } else {
            0.0
        };
        if !d.finite() || !d.hessian_finite() {
            return Err(Error::NonFinite {
                step: 0,
                what: "H, grad H or Hess H at zbar_0",
            });
        }
        if d.gradient.iter().all(|g| *g == 0.0) {
            return Err(Error::Equilibrium);
        }
        let tbar = if flags.time_dependent {
            // calH(zbar_0) must vanish (Theorem 1, eq. 11) to roundoff of its terms.
            let scale = zbar0.component_mul(&d.gradient).abs().sum().max(1.0);
            if d.value.abs() > options.residual_tolerance() * scale {
                return Err(Error::ExtendedEnergyNotZero { value: d.value });
            }
            zbar0[zbar0.len() / 2 - 1]
        } else {
            0.0
        };
        // Every midpoint is solved against this level: H(zbar_0) for autonomous H (eq. 30,
        // not the previous midpoint, so the energy cannot random-walk); exactly 0 for calH
        // (eq. 11).
        let energy = if flags.time_dependent { 0.0 } else { d.value };
        let s = State {
            k: 0,
            zbar: zbar0,
            lambda: options.lambda0(),
            tbar,
            gradient: d.gradient,
            psi: d.psi,
            iterations: 0,
            factorizations: 0,
            reported: false,
            psi_scale,
            // A start inside a band where Psi cancels starts with fallback steps.
            mode: if robust::cancellation_ratio(d.psi, psi_scale)
                < robust::leave_below(options.composition().coefficients().len())
            {
                Mode::Fallback
            } else {
                Mode::Dth
            },
            step_kind: StepKind::Dth,
            law: robust::law_through(options.lambda0(), d.psi, psi_scale).unwrap_or(0.0),
            h_edge: options.dtau() * options.composition().coefficients()[0],
            time_noise: 0.0,
            clock: (flags.regularized && flags.time_dependent).then(|| dim.value() / 2 - 1),
            compensated: (flags.regularized && flags.time_dependent).then(|| Compensated::new(dim)),
        };
        let work = Box::new(Workspace {
            newton: Work::new(dim),
            dense,
            v: zeros(dim),
            g: zeros(dim),
            sweep: zeros(dim),
            z1: zeros(dim),
            point: Point::zeros(dim),
            saved: s.clone(),
            record: empty_record(dim),
            saved_record: empty_record(dim),
            fallback: FallbackWork::new(&hamiltonian, options.robust()),
            walk: zeros(dim),
            scale,
        });
        let mut dth = Dth {
            hamiltonian,
            flags,
            options,
            energy,
            s,
            newton,
            work,
        };
        dth.refresh_record();
        Ok(dth)
    }

    /// The workspace's record made that of the current state again (after the state was set
    /// other than by a step, which writes its own): [`Dth::record_ref`] reads it.
    fn refresh_record(&mut self) {
        fill_record(&self.s, &mut self.work.record);
    }

    /// Start the clock at `tbar_0` instead of 0 (autonomous `H`; a time-dependent one reads
    /// its clock from the `t` coordinate of `zbar_0`).
    ///
    /// # Errors
    /// [`Error::InvalidOption`] (`tbar0`) when not finite, or when `H` is time-dependent (the
    /// clock would disagree with the `t` coordinate: set `t` in `zbar_0` instead).
    pub fn with_tbar0(mut self, tbar0: f64) -> Result<Self, Error> {
        let reason = if !tbar0.is_finite() {
            Some("must be finite")
        } else if self.flags.time_dependent {
            Some("a time-dependent H takes its clock from the t coordinate of zbar_0: set t there")
        } else {
            None
        };
        if let Some(reason) = reason {
            return Err(Error::InvalidOption {
                name: "tbar0",
                value: tbar0,
                reason,
            });
        }
        self.s.tbar = tbar0;
        self.refresh_record();
        Ok(self)
    }

    /// Start a regularized run from the midpoint `zbar_0 + low` instead of `zbar_0`, and solve
    /// every step in double-double (`dth::compensated`; about 20% more per step): the start
    /// in double-double, where doubles round what sets the orbit. For Kepler, `p_t = -E` sets
    /// the period (at e = 0.999 half an ulp of `E` moves the state after 100 orbits by 4e-10
    /// at the pericentre), and `K` at the rounded start, some 1e-16 off zero, is a
    /// gravitational parameter off by as much (4.9e-9 there). The regularized types'
    /// `start_double_double` gives both parts of the exact image of a physical start. The run
    /// carries the low part from step to step, [`Dth::low`] reads it, and its last step lands
    /// on `t_end` with the clock's low part. A Hamiltonian without a gradient in double-double
    /// ([`Hamiltonian::gradient_double_double_into`]) has its steps compensated as a run from
    /// doubles is.
    ///
    /// `zbar_0 + low` is rounded again into a midpoint and its low part (where a start rounded
    /// twice, `low` may be more than half an ulp), so `zbar_0` may move by an ulp.
    ///
    /// # Errors
    /// [`Error::WrongStateLength`] (`low`) for a length other than `D`;
    /// [`Error::InvalidOption`] (`low`) when `H` is not a regularization (only its runs carry
    /// a low part), or for an entry that is not finite or is more than 16 ulps of its
    /// coordinate (a low part holds what the coordinate's roundings dropped).
    pub fn with_low(mut self, low: OVector<f64, D>) -> Result<Self, Error> {
        if low.len() != self.s.zbar.len() {
            return Err(Error::WrongStateLength {
                what: "low",
                expected: self.s.zbar.len(),
                found: low.len(),
            });
        }
        let too_large = |(x, l): (&f64, &f64)| l.abs() > LOW_ULPS * ulp(*x);
        let invalid = match (&self.s.compensated, low.iter().find(|l| !l.is_finite())) {
            (None, _) => Some((
                0.0,
                "only a regularized run (in the extended phase space) carries a low part",
            )),
            (_, Some(&l)) => Some((l, "must be finite")),
            _ => self
                .s
                .zbar
                .iter()
                .zip(low.iter())
                .find(|p| too_large(*p))
                .map(|(_, &l)| (l, "each entry must be at most 16 ulps of its coordinate")),
        };
        if let Some((value, reason)) = invalid {
            return Err(Error::InvalidOption {
                name: "low",
                value,
                reason,
            });
        }
        let mut low = low;
        for (x, l) in self.s.zbar.iter_mut().zip(low.iter_mut()) {
            (*x, *l) = two_sum(*x, *l);
        }
        if let Some(c) = &mut self.s.compensated {
            c.start_from(&self.s.zbar, &low);
        }
        self.refresh_record();
        Ok(self)
    }

    /// The low part of the current midpoint of a regularized run: the run carries the
    /// midpoint `zbar + low` (`dth::compensated`; the clock `t` is `zbar`'s plus this one's
    /// entry). `None` for any other run.
    pub fn low(&self) -> Option<&OVector<f64, D>> {
        self.s.compensated.as_ref().map(Compensated::low)
    }

    /// `true` when steps solve the energy equation in the cancellation-free form
    /// ([`EnergyResidual`](super::EnergyResidual); `Auto` resolves on
    /// `flags().exact_divided_differences`).
    pub fn cancellation_free(&self) -> bool {
        match self.options.energy_residual() {
            EnergyResidual::Plain => false,
            EnergyResidual::CancellationFree => true,
            _ => self.flags.exact_divided_differences,
        }
    }

    /// The Hamiltonian.
    pub fn hamiltonian(&self) -> &H {
        &self.hamiltonian
    }
    /// The options.
    pub fn options(&self) -> &DthOptions {
        &self.options
    }
    /// Index `k` of the current midpoint.
    pub fn k(&self) -> usize {
        self.s.k
    }
    /// Current midpoint `zbar_k`.
    pub fn zbar(&self) -> &OVector<f64, D> {
        &self.s.zbar
    }
    /// Current multiplier `lambda_k`: the one the next step starts from. After a robust-mode
    /// fallback step it can differ from the step's record, which keeps that step's `dt / dtau`
    /// while the stepper holds the multiplier DTH resumes with (the law of time's).
    pub fn lambda(&self) -> f64 {
        self.s.lambda
    }
    /// Current midpoint time `tbar_k`.
    pub fn tbar(&self) -> f64 {
        self.s.tbar
    }
    /// The level every midpoint is solved against: `H(zbar_0)` (autonomous), or 0 for the
    /// extended-phase-space `calH`.
    pub fn energy(&self) -> f64 {
        self.energy
    }
    /// Slope `zbar'_k = lambda_k J gradH(zbar_k)` of the current segment.
    pub fn slope(&self) -> OVector<f64, D> {
        j_times(&self.s.gradient) * self.s.lambda
    }
    /// Left vertex `z^(k) = zbar_k - (h/2) zbar'_k` of the current segment (the node itself
    /// after a robust-mode fallback step). `h` is `dtau` at order 2; above, the segment of a
    /// composed step's end midpoint has the half-length of its last (and first) sub-step,
    /// `h = gamma_1 dtau` ([`Composition`](super::Composition)).
    pub fn left_vertex(&self) -> OVector<f64, D> {
        self.vertex(self.s.step_kind, -self.s.h_edge)
    }
    /// Right vertex `z^(k+1) = zbar_k + (h/2) zbar'_k` of the current segment (the node itself
    /// after a robust-mode fallback step); `h` as for [`Dth::left_vertex`].
    pub fn right_vertex(&self) -> OVector<f64, D> {
        self.vertex(self.s.step_kind, self.s.h_edge)
    }
    /// `zbar + (h/2) zbar'`, or the node itself after a fallback step.
    fn vertex(&self, kind: StepKind, h: f64) -> OVector<f64, D> {
        let mut out = self.s.zbar.clone();
        vertex_into(&self.s, kind, h, &mut out);
        out
    }
    /// What produced the current midpoint: the kind of its record ([`Dth::record_ref`], what
    /// the last step returned), [`StepKind::Shortened`] after [`Dth::step_toward`]'s last step
    /// and [`StepKind::Fallback`] after a robust-mode fallback step included.
    pub fn kind(&self) -> StepKind {
        self.work.record.kind
    }
    /// `true` when the robust mode's next step is a fallback step.
    pub fn in_fallback(&self) -> bool {
        self.s.mode == Mode::Fallback
    }
    /// The record of the current midpoint (an owned copy: two heap allocations for `Dyn`; see
    /// [`Dth::record_ref`]).
    pub fn record(&self) -> StepRecord<D> {
        self.work.record.clone()
    }

    /// The record of the current midpoint, borrowed: what [`Dth::step`] returned for it (or,
    /// before any step, the initial midpoint's). With [`Dth::advance`]`(1)` it steps one
    /// step at a time and reads each step without allocating, for a `Dyn` dimension too.
    ///
    /// ```
    /// use dth_core::dth::{Dth, DthOptions};
    /// use dth_core::{nalgebra::Vector4, systems::Kepler};
    /// let zbar0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    /// let mut dth = Dth::new(Kepler::thesis(), zbar0, DthOptions::thesis_kepler())?;
    /// let mut longest = 0.0_f64;
    /// while dth.tbar() < 10.0 {
    ///     dth.advance(1)?;
    ///     let record = dth.record_ref(); // borrowed: no copy of the state or the vertex
    ///     longest = longest.max(record.dth.as_ref().map_or(0.0, |d| d.lambda));
    /// }
    /// assert_eq!(dth.record_ref().z, *dth.zbar());
    /// assert!(longest > 1.0);
    /// # Ok::<(), dth_core::Error>(())
    /// ```
    pub fn record_ref(&self) -> &StepRecord<D> {
        &self.work.record
    }

    /// Advance one step: solve for `zbar_{k+1}`, `lambda_{k+1}` (in robust mode, possibly a
    /// fallback step instead; see [`DthOptions::with_robust`]). Above order 2
    /// ([`DthOptions::with_order`]) one step is the composition of `s` DTH steps
    /// `gamma_i dtau` ([`Dth::step_with`]); its record is the last sub-step's midpoint, with
    /// the Newton iterations of all of them. On error the state is unchanged (still at step
    /// `k`, also when a later sub-step fails). A failed step is not retried with a smaller `dtau`: the step
    /// equations depend on `h` only through `h lambda_k` and `h lambda_{k+1}`, so a smaller `h`
    /// that keeps the shared vertex `z^(k+1)` gives the same step, and one that does not breaks
    /// the continuity the vertex invariants (Theorems 3, 7) rest on. Where DTH has no positive
    /// root the robust mode is the way through; otherwise rerun with a smaller `dtau`.
    ///
    /// # Errors
    /// [`Error::Breakdown`] when `Psi` changes sign at the predicted midpoint or the predicted
    /// (or converged) `lambda_{k+1} / lambda_k` exceeds [`DthOptions::max_lambda_ratio`];
    /// [`Error::NewtonDiverged`], [`Error::SingularMatrix`], [`Error::NonFinite`] from Newton;
    /// [`Error::SpuriousRoot`] when it converges to `lambda_{k+1} <= 0`;
    /// [`Error::EnergyCheckFailed`] (cancellation-free residual, robust fallback).
    /// In robust mode these are carried through with fallback steps; what stops a run is a
    /// fallback step that fails (the discrete-gradient peer's `Method*` errors at the smallest
    /// size, [`Error::NonFinite`] where `H` itself is not finite, [`Error::EnergyCheckFailed`]).
    ///
    /// The record is an owned copy (for `Dyn`, two heap allocations);
    /// [`Dth::record_ref`] borrows it.
    pub fn step(&mut self) -> Result<StepRecord<D>, Error> {
        self.composed_step(
            self.options.composition().coefficients(),
            self.options.dtau(),
        )?;
        Ok(self.work.record.clone())
    }

    /// One plain DTH step (no composition, whatever [`DthOptions::order`]) with the signed
    /// step `dtau` in `tau`, from the current midpoint; `k` advances by one. A negative
    /// `dtau` runs backwards in time (`dt = lambda dtau < 0`; `lambda` stays positive). The
    /// map `(zbar_k, lambda_k) -> (zbar_{k+1}, lambda_{k+1})` is symmetric: `step_with(h)`
    /// followed by `step_with(-h)` returns to the start, to roundoff. A composed step of size
    /// `dtau` ([`Dth::step`] above order 2) is `step_with(gamma_i dtau)` for the coefficients
    /// `gamma_i` of [`DthOptions::composition`], bit for bit.
    ///
    /// ```
    /// use dth_core::dth::{Dth, DthOptions};
    /// use dth_core::{nalgebra::Vector4, systems::Kepler};
    /// let mut dth = Dth::new(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), DthOptions::thesis_kepler())?;
    /// dth.step_with(0.05)?;
    /// dth.step_with(-0.05)?;
    /// assert!((dth.zbar() - Vector4::new(0.5, 0.0, 0.0, 1.2)).amax() < 1e-14);
    /// assert!((dth.lambda() - 1.0).abs() < 1e-13 && dth.tbar().abs() < 1e-15);
    /// # Ok::<(), dth_core::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::InvalidOption`] (`dtau`) for zero or a non-finite `dtau`; otherwise as
    /// [`Dth::step`]. On error the state is unchanged.
    pub fn step_with(&mut self, dtau: f64) -> Result<StepRecord<D>, Error> {
        if !(dtau.is_finite() && dtau != 0.0) {
            return Err(Error::InvalidOption {
                name: "dtau",
                value: dtau,
                reason: "must be finite and nonzero",
            });
        }
        self.composed_step(&[1.0], dtau)?;
        Ok(self.work.record.clone())
    }

    /// Advance toward the time `t_end`, ending on it exactly: a full step ([`Dth::step`]) when
    /// it ends at least half a step before `t_end`; otherwise the last step, with its `dtau`
    /// scaled (by about 0.5 to 1.5) so that its final midpoint lands on `t = t_end` to
    /// roundoff, recorded as [`StepKind::Shortened`]. Returns the step's record and `true`
    /// once `t_end` is reached.
    ///
    /// The scale is the root of `tbar(s) - t_end`, where `tbar(s)` is the midpoint time after a
    /// step of `s dtau` from the current state (a smooth function, close to
    /// `tbar_k + s lambda dtau`), found by a secant iteration from `s = 0` and `s = 1`, each
    /// iterate a full (composed) step; it stops when the time is within `4 eps |t_end|`, the
    /// roundoff of the time sum, or when an iterate does not halve the distance to `t_end`
    /// (the noise of `tbar(s)` itself: with the plain energy residual each `lambda` carries a
    /// relative noise of about `eps / (h lambda)^2`, see
    /// [`EnergyResidual`](super::EnergyResidual)); the closest iterate is taken. Once a try
    /// overshoots, the root is bracketed, and a secant try outside the bracket or one that did
    /// not halve the distance is replaced by the bracket's midpoint (where `tbar(s)` is far
    /// from linear: a regularized `K`, whose physical time per step follows `|u|^2`, at a few
    /// steps per orbit). When the full step ended short of `t_end` and no stretched try lands,
    /// the full step is kept (`false` is returned) and the next call brackets `t_end`. A run
    /// that ends at a given time therefore reports its state at that time, with the order of
    /// the method, instead of overshooting by up to a step. The last step is an exact DTH
    /// step of its own `dtau` (energy at its midpoint is exact), but its segment's left vertex
    /// is not the previous segment's right vertex: the vertex invariants of order 2 (paper
    /// Theorem 7) jump once there, by `O(h^2)`. Costs about three extra steps per run where
    /// the time is nearly linear in the step, up to 64 tries where it is not.
    ///
    /// ```
    /// use dth_core::dth::{Dth, DthOptions};
    /// use dth_core::{nalgebra::Vector4, systems::Kepler};
    /// let options = DthOptions::thesis_kepler().with_order(4)?;
    /// let mut dth = Dth::new(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), options)?;
    /// let t_end = 11.245;
    /// while !dth.step_toward(t_end)?.1 {}
    /// assert!((dth.tbar() - t_end).abs() <= 4.0 * f64::EPSILON * t_end);
    /// # Ok::<(), dth_core::Error>(())
    /// ```
    ///
    /// In robust mode, a last step that cannot be scaled onto `t_end` this way (it changes
    /// kind with its size, or fails) is taken as fallback steps of exactly the time left.
    /// `true` is returned only when the midpoint landed on `t_end`: within `4 eps |t_end|`,
    /// or, with the plain energy residual, within twice the noise its `lambda`s put into the
    /// time.
    ///
    /// Once there, it stays: a call at `t_end` (the current midpoint time within that same
    /// tolerance) takes no step and returns the current record and `true`, so a loop
    /// `while !dth.step_toward(t_end)?.1 {}` may be entered at `t_end` or run again.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] (`t_end`) when `t_end` is not finite or before the current
    /// midpoint time; [`Error::EndNotReached`] when no try of the last step landed on
    /// `t_end`; otherwise as [`Dth::step`]. The state is then that of the last accepted step.
    pub fn step_toward(&mut self, t_end: f64) -> Result<(StepRecord<D>, bool), Error> {
        let reached = self.advance_toward(t_end)?;
        Ok((self.work.record.clone(), reached))
    }

    /// [`Dth::step_toward`] without the copy of the record (read it with
    /// [`Dth::record_ref`]): `true` once `t_end` is reached. What a driver that steps to a time
    /// calls per step, without allocating for a `Dyn` state.
    ///
    /// # Errors
    /// As [`Dth::step_toward`].
    pub fn advance_toward(&mut self, t_end: f64) -> Result<bool, Error> {
        let t0 = self.s.tbar;
        if !t_end.is_finite() {
            return Err(Error::InvalidOption {
                name: "t_end",
                value: t_end,
                reason: "must be finite",
            });
        }
        // The time sum's rounding; a landing is accepted within it plus twice the noise of the
        // landed try's time (the secant stops there: its tries differ by that much for the
        // same scale).
        let tolerance = end_tolerance(t0, t_end);
        let accepted = |gap: f64, time_noise: f64| gap <= tolerance + 2.0 * time_noise;
        // Already there, as a landing would accept it.
        if accepted((t0 - t_end).abs(), self.s.time_noise) {
            return Ok(true);
        }
        if t_end < t0 {
            return Err(Error::InvalidOption {
                name: "t_end",
                value: t_end,
                reason: "must not be before the current midpoint time",
            });
        }
        let dtau = self.options.dtau();
        // (It keeps the start, state and record, in `work.saved`, `work.saved_record`.)
        self.composed_step(self.options.composition().coefficients(), dtau)?;
        let full_t = self.work.record.t;
        if full_t < t_end - 0.5 * (full_t - t0) {
            return Ok(false);
        }
        self.land_last(t0, t_end)
    }

    /// The state at the time `t` within the last step (from its start's midpoint time to the
    /// current one), landed on beside the run: the last step redone from its start with its
    /// `dtau` scaled so that its midpoint lands on `t`, as [`Dth::step_toward`] lands a run's
    /// last step (and in robust mode, where that scaling cannot land, fallback steps of the
    /// time left). The stepper is then put back where it was, so a run that lands on chosen
    /// times this way takes the steps of a run without them. (A run that ends at `t` lands
    /// the same way, but may stretch the step before instead when `t` lies in the first half
    /// of this one.) The record is [`StepKind::Shortened`] (or
    /// [`StepKind::Fallback`]), its `k` the index of the last step; at either end of the
    /// step it is that state's own record.
    ///
    /// ```
    /// use dth_core::dth::{Dth, DthOptions};
    /// use dth_core::{nalgebra::Vector4, systems::Kepler, Hamiltonian};
    /// let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    /// let mut run = Dth::new(Kepler::thesis(), z0, DthOptions::thesis_kepler())?;
    /// while run.tbar() < 1.0 {
    ///     run.step()?;
    /// }
    /// let after = (run.zbar().clone(), run.tbar());
    /// let at_one = run.land_within_last(1.0)?;
    /// assert_eq!((run.zbar().clone(), run.tbar()), after); // the run is where it was
    /// assert!((at_one.t - 1.0).abs() <= 4.0 * f64::EPSILON);
    /// // An exact DTH midpoint: its energy is the start's, to roundoff.
    /// let h = Kepler::thesis();
    /// assert!((h.value(&at_one.z) - h.value(&z0)).abs() <= 8.0 * f64::EPSILON);
    /// # Ok::<(), dth_core::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::InvalidOption`] (`t`) for a time outside the last step;
    /// [`Error::EndNotReached`] when no try lands on `t`; the failures of [`Dth::step`]. The
    /// stepper is put back where it was in every case.
    pub fn land_within_last(&mut self, t: f64) -> Result<StepRecord<D>, Error> {
        self.within_last(t, false)
    }

    /// The last step redone to end at the time `t` within it, as [`Dth::land_within_last`]
    /// lands there, but kept: the run now ends there (where an event stopped it), and
    /// [`Dth::run`] reports that state (if it has not reported the full step) and its vertex.
    ///
    /// # Errors
    /// As [`Dth::land_within_last`]; the stepper is then where it was.
    pub fn end_within_last(&mut self, t: f64) -> Result<StepRecord<D>, Error> {
        self.within_last(t, true)
    }

    /// [`Dth::land_within_last`], the stepper put back unless `keep` (and the landing
    /// succeeded).
    fn within_last(&mut self, t: f64, keep: bool) -> Result<StepRecord<D>, Error> {
        let (t0, full_t) = (self.work.saved_record.t, self.work.record.t);
        let tolerance = end_tolerance(t0, t);
        if (t - t0).abs() <= tolerance + 2.0 * self.work.saved.time_noise {
            if keep {
                self.restore();
            }
            return Ok(self.work.saved_record.clone());
        }
        if (t - full_t).abs() <= tolerance + 2.0 * self.s.time_noise {
            return Ok(self.work.record.clone());
        }
        if !(t0 < t && t < full_t) {
            return Err(Error::InvalidOption {
                name: "t",
                value: t,
                reason: "must lie within the last step (from its start's midpoint time to the current one)",
            });
        }
        let kept = (
            self.s.clone(),
            self.work.record.clone(),
            self.work.saved.clone(),
            self.work.saved_record.clone(),
        );
        // The full step is the secant's first try; in robust mode a landing by fallback steps
        // may take more than one of them.
        let mut landed = self.land_last(t0, t);
        while let Ok(false) = landed {
            landed = self.advance_toward(t);
        }
        let record = landed.map(|_| self.work.record.clone());
        if keep && record.is_ok() {
            return record;
        }
        let (state, last, saved, saved_record) = kept;
        self.s.assign(&state);
        self.work.record.copy_from(&last);
        self.work.saved.assign(&saved);
        self.work.saved_record.copy_from(&saved_record);
        record
    }

    /// The end of [`Dth::advance_toward`] once the full step (the current state, from the
    /// saved start at `t0`) ends near or past `t_end`: the landing.
    fn land_last(&mut self, t0: f64, t_end: f64) -> Result<bool, Error> {
        let tolerance = end_tolerance(t0, t_end);
        let accepted = |gap: f64, time_noise: f64| gap <= tolerance + 2.0 * time_noise;
        let dtau = self.options.dtau();
        let full_t = self.work.record.t;
        // The last step: secant iteration on the scale s of dtau, F(s) = tbar(s) - t_end, from
        // F(0) = t0 - t_end < 0 and F(1) (just computed); in double-double, tbar(s) with its
        // low part.
        let target = if self
            .s
            .compensated
            .as_ref()
            .is_some_and(Compensated::double_double)
        {
            (END_TOLERANCE * f64::EPSILON * (full_t - t0).abs()).min(tolerance)
        } else {
            tolerance
        };
        let landing = Landing { t0, t_end, target };
        let gap = self.gap(t_end);
        let mut best = Best {
            gap: gap.abs(),
            state: self.s.clone(),
            record: self.work.record.clone(),
        };
        let start = (1.0, gap);
        // The full step, kept: where it ended short of t_end and no stretched try lands (the
        // time is far from linear in the step, as for a regularized K whose physical time per
        // step follows |u|^2), the run goes on from it and the next step brackets t_end.
        let short = (start.1 < 0.0).then(|| (best.state.clone(), best.record.clone()));
        let landed = self.land(&landing, End::Step, start, &mut best);
        if let Some((state, record)) =
            short.filter(|_| landed.is_err() || !accepted(best.gap, best.state.time_noise))
        {
            self.s.assign(&state);
            self.work.record.copy_from(&record);
            return Ok(false);
        }
        if self.options.robust() && (landed.is_err() || best.gap > tolerance) {
            // DTH's last step could not be scaled onto t_end (a step that changes kind with its
            // size, or a failure): fallback steps of exactly the time left (their time is
            // linear in their size; for a time-dependent H the t coordinate nearly so), then
            // the secant on their size; if the time left is more than the law of time's
            // fallback step here, or that step fails, fallback steps of at most that size
            // toward t_end until it is near enough.
            self.restore();
            let left = t_end - t0;
            let pieces = (left / (dtau * self.fallback_lambda())).ceil();
            if pieces <= 1.0 && self.fallback_from_start(left, false).is_ok() {
                let f = self.gap(t_end);
                best.offer(f, &self.s, &self.work.record);
                // A failure here leaves the best try so far.
                let _ = self.land(&landing, End::Fallback, (1.0, f), &mut best);
            }
            if !accepted(best.gap, best.state.time_noise) {
                // Not there in one step: one fallback step toward t_end (an equal share of
                // the time left, halved while it fails), and the next call goes on from it.
                self.restore();
                let share = if pieces.is_finite() {
                    pieces.max(2.0)
                } else {
                    2.0
                };
                self.fallback_from_start(left / share, true)?;
                return Ok(false);
            }
        } else {
            landed?;
        }
        let Best {
            gap,
            state,
            record: mut best_record,
        } = best;
        if !accepted(gap, state.time_noise) {
            self.restore();
            return Err(Error::EndNotReached {
                step: self.s.k + 1,
                t_end,
                reached: best_record.t,
            });
        }
        self.s.assign(&state);
        // Report it as shortened (a fallback inside it says more, and stays).
        if best_record.kind == StepKind::Dth {
            best_record.kind = StepKind::Shortened;
            self.s.step_kind = StepKind::Shortened;
        }
        self.work.record.copy_from(&best_record);
        Ok(true)
    }

    /// The secant iteration of [`Dth::step_toward`]'s last step on the scale `s` of its size
    /// (`dtau` for [`End::Step`], the time left for [`End::Fallback`]), from `s = 0` (the
    /// saved start) and `start = (s, F(s))`, `F(s) = tbar(s) - t_end`; every try is offered to
    /// `best`. It stops within the tolerance, or when a try does not halve the distance to
    /// `t_end` and either no bracket of the root is known or the best try is within the time's
    /// noise (the noise of `tbar(s)` itself). With a bracket (`F(lo) < 0 < F(hi)`, `tbar`
    /// increasing in `s`), a secant try outside it or one that did not halve the distance is
    /// replaced by the bracket's midpoint: where `tbar(s)` is far from linear (a regularized
    /// `K` at a few steps per orbit) the secant alone stalls short of `t_end`.
    fn land(
        &mut self,
        landing: &Landing,
        how: End,
        start: (f64, f64),
        best: &mut Best<D>,
    ) -> Result<(), Error> {
        let Landing {
            t0, t_end, target, ..
        } = *landing;
        let (mut s_a, mut f_a) = (0.0, (t0 - t_end) + self.work.saved.clock_low());
        let (mut s_b, mut f_b) = start;
        // (lo, hi) with F(lo) < 0 < F(hi), once known.
        let mut bracket = (f_b > 0.0).then_some((0.0, s_b));
        let mut bisect = false;
        for _ in 0..MAX_END_ITERATIONS {
            if best.gap <= target || f_b == f_a {
                break;
            }
            let secant = s_b - f_b * (s_b - s_a) / (f_b - f_a);
            let scale = match bracket {
                Some((lo, hi)) if bisect || !(lo < secant && secant < hi) => 0.5 * (lo + hi),
                // Inside the bracket, as small as it is: a time just after the step's start
                // (a landing beside the run, `land_within_last`) needs a scale near 0.
                Some(_) => secant,
                None => secant.clamp(1e-3, 4.0),
            };
            self.restore();
            match how {
                End::Step => self.composed_step(
                    self.options.composition().coefficients(),
                    scale * self.options.dtau(),
                )?,
                End::Fallback => self.fallback_from_start(scale * (t_end - t0), false)?,
            }
            let f = self.gap(t_end);
            let improved = f.abs() <= 0.5 * best.gap;
            best.offer(f, &self.s, &self.work.record);
            bracket = match bracket {
                Some((_, hi)) if f < 0.0 => Some((scale, hi)),
                Some((lo, _)) => Some((lo, scale)),
                // The last try below t_end: the previous one (s_b) when it lies below `scale`.
                None if f > 0.0 => Some((if s_b < scale { s_b } else { 0.0 }, scale)),
                None => None,
            };
            let at_noise = best.gap <= target + 2.0 * best.state.time_noise;
            if !improved && (bracket.is_none() || at_noise) {
                // At the noise of tbar(s): converged as far as it can.
                break;
            }
            bisect = !improved;
            (s_a, f_a) = (s_b, f_b);
            (s_b, f_b) = (scale, f);
        }
        Ok(())
    }

    /// `tbar - t_end` of the current state, with the time's low part where the run is solved
    /// in double-double.
    fn gap(&self, t_end: f64) -> f64 {
        (self.work.record.t - t_end) + self.s.clock_low()
    }

    /// Back at the start of the last composed step (state and record), which
    /// [`Dth::composed_step`] saved.
    fn restore(&mut self) {
        self.s.assign(&self.work.saved);
        self.work.record.copy_from(&self.work.saved_record);
    }

    /// One composed step of size `dtau`: the sub-steps `gamma_i dtau` in turn (`gammas` is
    /// the composition's coefficients, `[1.0]` for a single DTH step), all DTH steps or (robust
    /// mode) all fallback steps, so that each composed step is a method of the composition's
    /// order. In robust mode a composed DTH step that fails in a recoverable way (a breakdown,
    /// a Newton failure) is redone from its start as fallback steps, and the next step's kind
    /// is chosen at its end (see `dth::robust`). Its record (in the workspace) is the last
    /// sub-step's, with the iterations of every try summed. On error the state is restored to
    /// the start of the step.
    fn composed_step(&mut self, gammas: &[f64], dtau: f64) -> Result<(), Error> {
        self.work.saved.assign(&self.s);
        self.work.saved_record.copy_from(&self.work.record);
        let step = self.s.k + 1;
        let mut spent = Spent::default();
        let result = match self.s.mode {
            Mode::Dth => match self.dth_composed(gammas, dtau, step, &mut spent) {
                Err(e) if self.options.robust() && recoverable(&e) => {
                    self.s.assign(&self.work.saved);
                    self.fallback_composed(gammas, dtau * self.fallback_lambda(), step, &mut spent)
                }
                r => r,
            },
            Mode::Fallback => {
                self.fallback_composed(gammas, dtau * self.fallback_lambda(), step, &mut spent)
            }
        };
        if let Err(e) = result {
            self.restore();
            return Err(e);
        }
        self.finish_step(step, dtau, spent);
        Ok(())
    }

    /// A step of [`Dth::step_toward`] as fallback steps of total physical size `dt` (composed
    /// like the run's steps), from the saved start; with `halve`, a try that fails is redone
    /// at half the size (see [`Dth::fallback_composed`]), so the step may end short of `dt`.
    fn fallback_from_start(&mut self, dt: f64, halve: bool) -> Result<(), Error> {
        let step = self.s.k + 1;
        let mut spent = Spent::default();
        let gammas = self.options.composition().coefficients();
        let result = if halve {
            self.fallback_composed(gammas, dt, step, &mut spent)
        } else {
            self.fallback_sub_steps(gammas, dt, step, &mut spent)
        };
        if let Err(e) = result {
            self.restore();
            return Err(e);
        }
        self.finish_step(step, self.options.dtau(), spent);
        Ok(())
    }

    /// Write the record of a composed step that ended at the current state (the last
    /// sub-step's midpoint or node), and choose the robust mode's next step there.
    fn finish_step(&mut self, step: usize, dtau: f64, spent: Spent) {
        self.s.k = step;
        self.s.iterations = spent.iterations;
        self.s.factorizations = spent.factorizations;
        self.s.time_noise = spent.time_noise;
        self.s.reported = false;
        if self.s.step_kind == StepKind::Fallback {
            // A fallback node carries lambda = dt / dtau of its step.
            self.s.lambda = spent.fallback_dt / dtau;
        }
        fill_record(&self.s, &mut self.work.record);
        if !self.options.robust() {
            return;
        }
        if self.s.law == 0.0 {
            self.s.law =
                robust::law_through(self.s.lambda, self.s.psi, self.s.psi_scale).unwrap_or(0.0);
        }
        let ratio = robust::cancellation_ratio(self.s.psi, self.s.psi_scale);
        let leave = robust::leave_below(self.options.composition().coefficients().len());
        match self.s.mode {
            Mode::Dth if ratio < leave => self.s.mode = Mode::Fallback,
            Mode::Fallback if ratio >= robust::RESUME_ABOVE => {
                // Resume DTH at this node, with the lambda of the run's law of time (the
                // record keeps the fallback step's).
                if let Some(lambda) = robust::lambda_of(self.s.law, self.s.psi, self.s.psi_scale) {
                    self.s.mode = Mode::Dth;
                    self.s.lambda = lambda;
                }
            }
            _ => {}
        }
    }

    /// The multiplier of a fallback step from the current state: the robust mode's law of time
    /// (`dth::robust`), or the current `lambda` where that is not defined (`Psi` and its scale
    /// zero at a point, or no law yet).
    fn fallback_lambda(&self) -> f64 {
        robust::lambda_of(self.s.law, self.s.psi, self.s.psi_scale).unwrap_or(self.s.lambda)
    }

    /// The DTH sub-steps of a composed step; in robust mode each midpoint's `Psi_scale` is
    /// evaluated, and at order 4-8 a midpoint inside a band where `Psi` cancels
    /// ([`robust::LEAVE_BELOW_COMPOSED`]) fails the step as a breakdown.
    fn dth_composed(
        &mut self,
        gammas: &[f64],
        dtau: f64,
        step: usize,
        spent: &mut Spent,
    ) -> Result<(), Error> {
        for &gamma in gammas {
            let solved = self.dth_step(gamma * dtau, step);
            match &solved {
                Ok(()) => {
                    spent.add(self.s.iterations, self.s.factorizations);
                    spent.time_noise += self.s.time_noise;
                }
                Err(Error::NewtonDiverged { iterations, .. }) => {
                    spent.add(*iterations, *iterations)
                }
                Err(_) => {}
            }
            solved?;
            if self.options.robust() {
                let ratio = robust::cancellation_ratio(self.s.psi, self.s.psi_scale);
                if gammas.len() > 1 && ratio < robust::LEAVE_BELOW_COMPOSED {
                    return Err(Error::Breakdown {
                        step,
                        time: self.work.saved.tbar,
                        psi: self.s.psi,
                        psi_previous: self.work.saved.psi,
                        lambda: self.work.saved.lambda,
                        lambda_predicted: self.s.lambda,
                    });
                }
            }
        }
        self.s.step_kind = StepKind::Dth;
        Ok(())
    }

    /// The fallback sub-steps of a composed step of total physical size `dt` (signed), from
    /// the current state; where one fails in a way a smaller step can cure (its Newton, a
    /// non-finite value), all are redone from the start at half the size, down to
    /// `2^-MAX_FALLBACK_HALVINGS`; below that the run stops with the fallback's error (the
    /// orbit cannot be followed, e.g. into a region where `H` is not finite).
    fn fallback_composed(
        &mut self,
        gammas: &[f64],
        mut dt: f64,
        step: usize,
        spent: &mut Spent,
    ) -> Result<(), Error> {
        let mut halvings = 0;
        loop {
            match self.fallback_sub_steps(gammas, dt, step, spent) {
                Ok(()) => return Ok(()),
                Err(
                    Error::MethodNotConverged { .. }
                    | Error::MethodSingularMatrix { .. }
                    | Error::MethodNonFinite { .. }
                    | Error::NonFinite { .. },
                ) if halvings < MAX_FALLBACK_HALVINGS => {
                    self.s.assign(&self.work.saved);
                    dt *= 0.5;
                    halvings += 1;
                }
                Err(e) => return Err(e),
            }
        }
    }

    /// Fallback steps `gamma_i dt` in turn from the current state (a symmetric composition of
    /// the symmetric discrete-gradient step, of the composition's order), each checked and
    /// projected onto the energy level. The time of the last node is `t_0 + dt` in one
    /// rounding (autonomous `H`), the `t` coordinate for a time-dependent one.
    fn fallback_sub_steps(
        &mut self,
        gammas: &[f64],
        dt: f64,
        step: usize,
        spent: &mut Spent,
    ) -> Result<(), Error> {
        let t0 = self.s.tbar;
        let mut elapsed = 0.0;
        for (i, &gamma) in gammas.iter().enumerate() {
            let w = &mut *self.work;
            let mut path = linear::path(&self.hamiltonian, &mut self.newton, &mut w.dense);
            let iterations = fallback_step(
                &self.hamiltonian,
                &self.s.zbar,
                gamma * dt,
                self.energy,
                &self.options,
                step,
                &mut path,
                &mut w.fallback,
            )?;
            spent.add(iterations, iterations);
            std::mem::swap(&mut self.s.zbar, &mut w.fallback.z);
            std::mem::swap(&mut self.s.gradient, &mut w.fallback.point.gradient);
            self.s.psi = w.fallback.point.psi;
            if i + 1 == gammas.len() {
                // Only the composed step's end decides the next step and sizes it.
                self.s.psi_scale = robust::psi_scale(&path, &self.s.gradient, &mut w.scale);
            }
            elapsed += gamma;
            // Extended phase space: time is the t coordinate (Gonzalez's discrete gradient moves
            // it by dt (1 + O(dt^2)), not exactly dt).
            self.s.tbar = if self.flags.time_dependent {
                self.s.zbar[self.s.zbar.len() / 2 - 1]
            } else if i + 1 == gammas.len() {
                t0 + dt
            } else {
                t0 + elapsed * dt
            };
            self.s.h_edge = gamma * self.options.dtau();
        }
        spent.fallback_dt = dt;
        self.s.step_kind = StepKind::Fallback;
        Ok(())
    }

    /// A Newton failure (or a root with `lambda <= 0`) where `Psi` changes sign just ahead on
    /// the orbit is the method's breakdown, not the solver's: walk up to
    /// [`DIAGNOSE_STEPS`] energy-conserving discrete-gradient steps of the current physical
    /// size `lambda_k h` (signed, this sub-step's) from `zbar_k` (points on the orbit, unlike an explicit predictor
    /// with a large step) and report [`Error::Breakdown`] at the first sign change of `Psi`;
    /// otherwise keep the solver's error. Runs only after a failure.
    fn diagnose(&mut self, error: Error, time: f64, h: f64) -> Error {
        let step = match error {
            Error::NewtonDiverged { step, .. }
            | Error::SingularMatrix { step }
            | Error::SpuriousRoot { step, .. } => step,
            _ => return error,
        };
        let dt = self.s.lambda * h;
        let w = &mut *self.work;
        w.walk.copy_from(&self.s.zbar);
        for _ in 0..DIAGNOSE_STEPS {
            let walked = fallback_step(
                &self.hamiltonian,
                &w.walk,
                dt,
                self.energy,
                &self.options,
                step,
                &mut linear::path(&self.hamiltonian, &mut self.newton, &mut w.dense),
                &mut w.fallback,
            );
            if walked.is_err() {
                break;
            }
            let psi = w.fallback.point.psi;
            if self.s.psi * psi < 0.0 {
                return Error::Breakdown {
                    step,
                    time,
                    psi,
                    psi_previous: self.s.psi,
                    lambda: self.s.lambda,
                    lambda_predicted: self.s.lambda * (self.s.psi / psi).cbrt(),
                };
            }
            std::mem::swap(&mut w.walk, &mut w.fallback.z);
        }
        error
    }

    /// One DTH step of signed size `h` with breakdown detection (every part of it holds for
    /// `h < 0`: the predictor, the law of time and the checks read `h` only through
    /// `h lambda`, and Newton's matrix and `g_lambda ~ -lambda h^2 Psi / 4` keep their form).
    fn dth_step(&mut self, h: f64, step: usize) -> Result<(), Error> {
        let cancellation_free = self.cancellation_free();
        let ham = &self.hamiltonian;
        let w = &mut *self.work;
        // The current point is a midpoint (or, where DTH resumes, a fallback node taken as one).
        vertex_into(&self.s, StepKind::Dth, h, &mut w.v);
        // Predict lambda from the asymptotic law of time (paper Theorem 5):
        // lambda psi^(1/3) ~ const, with psi at an explicit predictor of zbar_{k+1}; fall back
        // to lambda_k where psi vanishes. A sign change of psi, or a predicted lambda that blows
        // up, means the step has no positive root near lambda_k: stop before Newton wanders.
        predict_into(
            ham,
            &w.v,
            self.s.lambda,
            h,
            (&mut w.g, &mut w.sweep),
            &mut w.z1,
        );
        let (time, psi_previous, lambda) = (self.s.tbar, self.s.psi, self.s.lambda);
        let max_ratio = self.options.max_lambda_ratio();
        // Psi exactly zero at either point (ratio 0, infinite or NaN), or a predictor too far
        // off the energy surface to say where the orbit goes, is no verdict: Newton decides
        // (and a failure is diagnosed along the orbit).
        let verdict = |psi: Option<f64>| -> Result<Option<f64>, Error> {
            let Some(psi) = psi else { return Ok(None) };
            let ratio = psi_previous / psi;
            let predicted = lambda * ratio.cbrt();
            if ratio < 0.0 || (ratio.is_finite() && predicted > max_ratio * lambda) {
                return Err(Error::Breakdown {
                    step,
                    time,
                    psi,
                    psi_previous,
                    lambda,
                    lambda_predicted: predicted,
                });
            }
            Ok((predicted.is_finite() && predicted > 0.0).then_some(predicted))
        };
        let mut path = linear::path(ham, &mut self.newton, &mut w.dense);
        let evaluated = predicted(ham, &mut path, &w.z1, &mut w.point);
        let psi1 = evaluated
            .then(|| trusted_psi(self.energy, &w.z1, &w.point))
            .flatten();
        let lambda_guess = verdict(psi1)?.unwrap_or(self.s.lambda);
        // Newton's start. With c = (h/2) lambda_k, c' = (h/2) lambda_guess and the fixed point
        // z* = v + c' J gradH(z*), a third fixed-point sweep at c' with the gradient the check
        // above evaluated at z1 (no further evaluation) errs by about
        // c' |Hess| |z1 - z*| ~ c' |c - c'| |Hess| |gradH| (plus O(c^4)), two fresh sweeps at c'
        // from v by about c'^3 |Hess|^2 |gradH|: take the sweep when |c - c'| <= c'^2 |Hess|
        // (both sides are O(h^2) on a smooth orbit, where lambda_{k+1} - lambda_k = O(h lambda_k):
        // the test compares their constants) and z1 is trusted to lie near the orbit; else two
        // sweeps at c' (a step far too large, or lambda changing fast). After the third sweep,
        // up to two more refine the start while they contract (`refine_start`).
        let c = 0.5 * h * self.s.lambda;
        let c_guess = 0.5 * h * lambda_guess;
        let mut start_evaluated = false;
        let near = evaluated
            && psi1.is_some()
            && (c - c_guess).abs() <= c_guess * c_guess * w.point.hessian_max;
        let look_again = lambda_guess > LOOK_AGAIN * self.s.lambda;
        // (Starting Newton at z1 itself on the evaluation just made, one evaluation fewer, was
        // measured: 4.54 iterations and 3.16 factorizations per thesis Kepler step against
        // 3.93 and 2.34 from the sweep, and slower.)
        if near {
            add_j_times(&w.v, &w.point.gradient, c_guess, &mut w.newton.z);
            // Not where lambda grows fast: its prediction is then the larger error.
            if !look_again {
                refine_start(
                    ham,
                    (&w.v, c_guess),
                    &w.z1,
                    &mut w.newton.z,
                    (&mut w.g, &mut w.sweep),
                );
            }
        } else {
            predict_into(
                ham,
                &w.v,
                lambda_guess,
                h,
                (&mut w.g, &mut w.sweep),
                &mut w.newton.z,
            );
        }
        if look_again {
            // Look again where the law of time says the midpoint will be: further out when
            // lambda grows fast, as it does towards Psi = 0 (one more evaluation of H's
            // derivatives, so only then).
            let z0 = &w.newton.z;
            let again = predicted(ham, &mut path, z0, &mut w.point);
            verdict(
                again
                    .then(|| trusted_psi(self.energy, z0, &w.point))
                    .flatten(),
            )?;
            // Newton starts with this evaluation (the solver holds its Hessian).
            if again {
                std::mem::swap(&mut w.newton.e.d, &mut w.point);
                start_evaluated = true;
            }
        }
        let previous = cancellation_free.then_some(Previous {
            zbar: &self.s.zbar,
            gradient: &self.s.gradient,
            lambda: self.s.lambda,
        });
        let anchor = Anchor {
            v: &w.v,
            energy: self.energy,
            previous,
        };
        let solved = solve_segment(
            ham,
            &anchor,
            (lambda_guess, start_evaluated),
            h,
            &self.options,
            step,
            &mut self.newton,
            &mut w.dense,
            &mut w.newton,
        );
        let s = match solved {
            Ok(s) => s,
            Err(e) => return Err(self.diagnose(e, time, h)),
        };
        if s.lambda <= 0.0 {
            return Err(self.diagnose(
                Error::SpuriousRoot {
                    step,
                    lambda: s.lambda,
                },
                time,
                h,
            ));
        }
        let w = &mut *self.work;
        if s.lambda > self.options.max_lambda_ratio() * self.s.lambda {
            return Err(Error::Breakdown {
                step,
                time,
                psi: w.newton.e.d.psi,
                psi_previous,
                lambda,
                lambda_predicted: s.lambda,
            });
        }
        if let Some(c) = &mut self.s.compensated {
            c.carry(&self.s.zbar, &w.newton.z);
        }
        if cancellation_free {
            let from_scale = roundoff_scale(&self.s.zbar, &self.s.gradient);
            project(
                &self.hamiltonian,
                self.energy,
                &mut w.newton,
                from_scale,
                &self.options,
                step,
                &mut linear::path(&self.hamiltonian, &mut self.newton, &mut w.dense),
            )?;
        }
        self.s.tbar += 0.5 * h * (self.s.lambda + s.lambda);
        if let Some(c) = &mut self.s.compensated {
            let old = (&self.s.zbar, &self.s.gradient, self.s.lambda);
            c.settle_exact(
                &self.hamiltonian,
                &mut linear::path(&self.hamiltonian, &mut self.newton, &mut w.dense),
                h,
                old,
                (&mut w.newton.z, &w.newton.e.d.gradient, s.lambda),
            );
        }
        if let Some(i) = self.s.clock {
            self.s.tbar = w.newton.z[i];
        }
        self.s.lambda = s.lambda;
        std::mem::swap(&mut self.s.zbar, &mut w.newton.z);
        std::mem::swap(&mut self.s.gradient, &mut w.newton.e.d.gradient);
        self.s.psi = w.newton.e.d.psi;
        self.s.iterations = s.iterations;
        self.s.factorizations = s.factorizations;
        self.s.h_edge = h;
        self.s.time_noise = (h * s.lambda).abs() * s.noise;
        if self.options.robust() {
            // The solver holds the Hessian at the solution (or at its projection onto the
            // energy level, a roundoff away).
            let path = linear::path(&self.hamiltonian, &mut self.newton, &mut w.dense);
            self.s.psi_scale = robust::psi_scale(&path, &self.s.gradient, &mut w.scale);
        }
        Ok(())
    }

    /// Take `steps` steps, reporting to `observer`: first the current midpoint if not reported
    /// yet, then each new one, and finally (also after a failure) the right vertex of the last
    /// accepted segment. On error the stepper stays at the last accepted step and the
    /// observer holds everything before it.
    ///
    /// # Errors
    /// The first failing step's error (see [`Dth::step`]).
    pub fn run<O: Observer<D>>(&mut self, steps: usize, observer: &mut O) -> Result<(), Error> {
        if !self.s.reported {
            observer.on_step(&self.work.record);
            self.s.reported = true;
        }
        let mut result = Ok(());
        for _ in 0..steps {
            let gammas = self.options.composition().coefficients();
            match self.composed_step(gammas, self.options.dtau()) {
                Ok(()) => {
                    observer.on_step(&self.work.record);
                    self.s.reported = true;
                }
                Err(e) => {
                    result = Err(e);
                    break;
                }
            }
        }
        let w = &mut *self.work;
        vertex_into(&self.s, self.s.step_kind, self.s.h_edge, &mut w.walk);
        let t_end = match self.s.clock {
            Some(i) => w.walk[i],
            None => self.s.tbar + 0.5 * self.s.h_edge * self.s.lambda,
        };
        observer.on_finish(&w.walk, t_end);
        result
    }

    /// [`Dth::run`] with a closure, whose record type is inferred (`run(n, &mut |r| ..)`
    /// needs it spelled: `&StepRecord<Const<4>>`).
    ///
    /// ```
    /// use dth_core::{nalgebra::Vector4, systems::Kepler, Dth, DthOptions};
    /// let mut dth = Dth::new(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), DthOptions::thesis_kepler())?;
    /// let mut largest_lambda = 0.0_f64;
    /// dth.run_with(100, |r| largest_lambda = largest_lambda.max(r.dth.as_ref().map_or(0.0, |d| d.lambda)))?;
    /// assert!(largest_lambda > 1.0);
    /// # Ok::<(), dth_core::Error>(())
    /// ```
    ///
    /// # Errors
    /// As [`Dth::run`].
    pub fn run_with<F: FnMut(&StepRecord<D>)>(
        &mut self,
        steps: usize,
        mut f: F,
    ) -> Result<(), Error> {
        self.run(steps, &mut f)
    }

    /// Take `steps` steps and return them as a [`Trajectory`] (starting with the current
    /// midpoint), or the error with the partial trajectory.
    ///
    /// # Errors
    /// [`RunError`] with the first failing step's error and the trajectory up to the last
    /// accepted step.
    // A run fails at most once, so the size of the `Err` (the partial trajectory's vectors)
    // costs nothing per step; boxing it would only make callers unwrap a box.
    #[allow(clippy::result_large_err)]
    pub fn trajectory(&mut self, steps: usize) -> Result<Trajectory<D>, RunError<Trajectory<D>>> {
        self.s.reported = false;
        let mut t = Trajectory::new();
        match self.run(steps, &mut t) {
            Ok(()) => Ok(t),
            Err(error) => Err(RunError { error, partial: t }),
        }
    }

    /// One (composed) step, not reported yet: the next [`Dth::run`] reports it. (What a
    /// driver calls when it looks at a step before its observer does.)
    pub(crate) fn step_unreported(&mut self) -> Result<(), Error> {
        self.composed_step(
            self.options.composition().coefficients(),
            self.options.dtau(),
        )
    }

    /// Take `steps` steps without storing anything.
    ///
    /// # Errors
    /// As [`Dth::run`].
    pub fn advance(&mut self, steps: usize) -> Result<(), Error> {
        self.run(steps, &mut ())
    }
}

/// Integrate `steps` DTH steps from the initial midpoint `zbar0`: the [`Trajectory`] of
/// `steps + 1` midpoints and `steps + 2` vertices.
///
/// ```
/// use dth_core::{dth::{integrate, DthOptions}, nalgebra::Vector4, systems::Kepler};
/// let options = DthOptions::new(0.06277)?.with_lambda0(1.0)?;
/// let t = integrate(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), options, 1000)?;
/// let mean_lambda = t.lambdas().iter().sum::<f64>() / t.len() as f64;
/// assert!((mean_lambda - 2.39).abs() < 0.05); // thesis: 25 points per orbit
/// # Ok::<(), dth_core::Error>(())
/// ```
///
/// # Errors
/// [`RunError`] with the construction error and an empty trajectory, or the first failing
/// step's error and the trajectory up to the last accepted step. `?` converts it into
/// [`Error`] (dropping the partial trajectory).
#[allow(clippy::result_large_err)] // see `Dth::trajectory`
pub fn integrate<H: Hamiltonian<D>, D: Dim>(
    hamiltonian: H,
    zbar0: OVector<f64, D>,
    options: DthOptions,
    steps: usize,
) -> Result<Trajectory<D>, RunError<Trajectory<D>>>
where
    DefaultAllocator: Alloc<D>,
{
    match Dth::new(hamiltonian, zbar0, options) {
        Ok(mut dth) => dth.trajectory(steps),
        Err(error) => Err(RunError {
            error,
            partial: Trajectory::new(),
        }),
    }
}

/// Refine Newton's start `z` (the third fixed-point sweep, taken from `z1`, the second) by up to
/// [`START_SWEEPS`] more sweeps `z <- v + c J grad H(z)` at the predicted `c = (h/2) lambda`,
/// each kept only while the sweeps contract by [`START_CONTRACTION`] (the contraction factor
/// is `c |J Hess H|`, which a large step can push towards 1). The stepper skips them where
/// `lambda` is predicted to grow fast (towards `Psi = 0`).
///
/// The sweeps cost a gradient each; what they buy is Newton's first update. From the
/// three-sweep start its relative size is `O(h^3)` (about 1e-7 on regularized Kepler at 23
/// DTH-8 steps per orbit), and the energy equation, whose sensitivity to `lambda` is
/// `g_lambda = O(h^2)`, turns that into a `lambda` error Newton needs a third update for. Two
/// more sweeps take the start to the error of the predicted `lambda` (1e-10 to 1e-12 there),
/// and Newton converges in two updates: 2.0 iterations per sub-step instead of 2.9, about a
/// tenth of the run's time (`docs/performance.md`, "Eccentric Kepler").
fn refine_start<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    (v, c): (&OVector<f64, D>, f64),
    z1: &OVector<f64, D>,
    z: &mut OVector<f64, D>,
    (g, next): (&mut OVector<f64, D>, &mut OVector<f64, D>),
) where
    DefaultAllocator: Alloc<D>,
{
    let change = |a: &OVector<f64, D>, b: &OVector<f64, D>| {
        a.iter()
            .zip(b.iter())
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
    };
    let mut last = change(z, z1);
    for _ in 0..START_SWEEPS {
        ham.gradient_into(z, g);
        add_j_times(v, g, c, next);
        let moved = change(next, z);
        // (A NaN change does not contract either.)
        let contracts = moved <= START_CONTRACTION * last;
        if !contracts {
            return;
        }
        std::mem::swap(z, next);
        last = moved;
    }
}

/// `H` at a predicted midpoint `z` into `out`, through the stepper's linear algebra: `true`
/// if `z`, the value and the gradient are finite.
fn predicted<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    solver: &mut L,
    z: &OVector<f64, D>,
    out: &mut Point<D>,
) -> bool
where
    DefaultAllocator: Alloc<D>,
{
    if !all_finite(z) {
        return false;
    }
    solver.evaluate(ham, z, out);
    out.finite()
}

/// `Psi` at a predicted midpoint, if finite and if the prediction lies on the energy
/// surface to within [`PREDICTOR_TRUST`] of the size of the terms of `H` (a predictor for a
/// step far too large for the orbit lands elsewhere in phase space, where `Psi` says
/// nothing about this orbit).
fn trusted_psi<D: Dim>(energy: f64, z: &OVector<f64, D>, d: &Point<D>) -> Option<f64>
where
    DefaultAllocator: Alloc<D>,
{
    let scale = energy.abs().max(roundoff_scale(z, &d.gradient));
    ((d.value - energy).abs() <= PREDICTOR_TRUST * scale && d.psi.is_finite()).then_some(d.psi)
}

/// `out = zbar + (h/2) zbar'` with the slope `zbar' = lambda J grad H(zbar)` of the state's
/// segment, or the node itself after a fallback step.
fn vertex_into<D: Dim>(s: &State<D>, kind: StepKind, h: f64, out: &mut OVector<f64, D>)
where
    DefaultAllocator: Alloc<D>,
{
    match kind {
        StepKind::Fallback => out.copy_from(&s.zbar),
        _ => {
            // zbar + (lambda J g) (h/2), rounded as written.
            let n = s.zbar.len() / 2;
            let half = 0.5 * h;
            for i in 0..n {
                out[i] = s.zbar[i] + (s.gradient[i + n] * s.lambda) * half;
                out[i + n] = s.zbar[i + n] + (-s.gradient[i] * s.lambda) * half;
            }
        }
    }
}

/// The record of the state's midpoint, written into `record` (its `dth` part is `Some`).
/// A DTH record of dimension `d` with every field zero: storage for [`fill_record`].
fn empty_record<D: Dim>(d: D) -> StepRecord<D>
where
    DefaultAllocator: Alloc<D>,
{
    StepRecord {
        k: 0,
        t: 0.0,
        z: zeros(d),
        kind: StepKind::Dth,
        iterations: 0,
        factorizations: 0,
        dth: Some(DthRecord {
            lambda: 0.0,
            vertex: zeros(d),
            vertex_time: 0.0,
            psi: 0.0,
        }),
    }
}

fn fill_record<D: Dim>(s: &State<D>, record: &mut StepRecord<D>)
where
    DefaultAllocator: Alloc<D>,
{
    let h = s.h_edge;
    let kind = s.step_kind;
    record.k = s.k;
    record.t = s.tbar;
    record.z.copy_from(&s.zbar);
    record.kind = kind;
    record.iterations = s.iterations;
    record.factorizations = s.factorizations;
    let vertex_time = match kind {
        StepKind::Fallback => s.tbar,
        _ => s.tbar - 0.5 * h * s.lambda,
    };
    match &mut record.dth {
        Some(d) => {
            vertex_into(s, kind, -h, &mut d.vertex);
            d.lambda = s.lambda;
            d.vertex_time = s.clock.map_or(vertex_time, |i| d.vertex[i]);
            d.psi = s.psi;
        }
        None => {
            let mut vertex = s.zbar.clone();
            vertex_into(s, kind, -h, &mut vertex);
            record.dth = Some(DthRecord {
                lambda: s.lambda,
                vertex_time: s.clock.map_or(vertex_time, |i| vertex[i]),
                vertex,
                psi: s.psi,
            });
        }
    }
}

/// How large [`Dth::with_low`] takes a low part to be at most, in ulps of its coordinate.
const LOW_ULPS: f64 = 16.0;

/// The spacing of doubles at `x` (the smallest subnormal at zero).
fn ulp(x: f64) -> f64 {
    let x = x.abs();
    x.next_up() - x
}
