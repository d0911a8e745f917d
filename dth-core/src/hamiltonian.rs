//! The [`Hamiltonian`] trait: value, gradient, Hessian and Psi of `H(z)`, generic over the
//! phase-space dimension as nalgebra's [`Dim`]: `Const<N>` for a dimension fixed when the
//! program is compiled (fixed-size `SVector`s, the `hamiltonian!` macro's types), `Dyn` for one
//! known only at run time (a Hamiltonian read from text).
//!
//! A hand-written implementation names its dimension, its flags, and writes its gradient and
//! Hessian into the caller's storage (`SVector<f64, 2>` is `OVector<f64, Const<2>>`):
//!
//! ```
//! use dth_core::nalgebra::{Const, Matrix2, Vector2};
//! use dth_core::{Flags, Hamiltonian};
//!
//! /// `H = (p^2 + q^2) / 2`.
//! struct Oscillator;
//! impl Hamiltonian<Const<2>> for Oscillator {
//!     fn dim(&self) -> Const<2> { Const }
//!     fn flags(&self) -> Flags { Flags::default().with_separable(true) }
//!     fn value(&self, z: &Vector2<f64>) -> f64 { 0.5 * z.norm_squared() }
//!     fn gradient_into(&self, z: &Vector2<f64>, out: &mut Vector2<f64>) { *out = *z; }
//!     fn hessian_into(&self, _: &Vector2<f64>, out: &mut Matrix2<f64>) {
//!         *out = Matrix2::identity();
//!     }
//! }
//! let z = Vector2::new(1.0, 0.0);
//! assert_eq!(Oscillator.gradient(&z), z); // by-value conveniences for users and tests
//! assert_eq!(Oscillator.psi(&z), 1.0);
//! ```

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector, U1, U2};

/// The storage bounds every dimension `D` of the crate needs, in one name: vectors
/// (`OVector<f64, D>`, `OVector<usize, D>`), square matrices (`OMatrix<f64, D, D>`) and the
/// two-column stage matrices of the 2-stage Gauss-Legendre method (`OMatrix<f64, D, U2>`).
/// Generic code writes `where DefaultAllocator: Alloc<D>`; it holds for every `Const<N>` and
/// for `Dyn`.
pub trait Alloc<D: Dim>: Allocator<D> + Allocator<D, D> + Allocator<D, U2> {}

impl<D: Dim, A: Allocator<D> + Allocator<D, D> + Allocator<D, U2>> Alloc<D> for A {}

/// A zero vector of dimension `d` (no allocation for `Const<N>`).
pub fn zeros<D: Dim>(d: D) -> OVector<f64, D>
where
    DefaultAllocator: Alloc<D>,
{
    OVector::zeros_generic(d, U1)
}

/// A zero `d x d` matrix (no allocation for `Const<N>`).
pub fn zeros_matrix<D: Dim>(d: D) -> OMatrix<f64, D, D>
where
    DefaultAllocator: Alloc<D>,
{
    OMatrix::zeros_generic(d, d)
}

/// What a Hamiltonian declares about itself, read once when a stepper or method is built.
///
/// `hamiltonian!` derives them from the expression; a hand-written implementation sets the
/// ones that hold (all `false` by default) with the `with_*` methods.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags {
    /// The implementation is the extended-phase-space `calH = p_t + H(t, q, p)`.
    pub time_dependent: bool,
    /// `H = T(p) + V(q)` (the q-p block of the Hessian is identically zero).
    pub separable: bool,
    /// `Psi` is identically zero (e.g. `H` linear, a free particle): DTH is undetermined
    /// there (thesis Section 3.4), the peer methods are not.
    pub psi_identically_zero: bool,
    /// [`Hamiltonian::discrete_gradient_into`] and
    /// [`Hamiltonian::discrete_gradient_defect_into`] are computed from exact divided
    /// differences, without cancellation as `z1 -> z0` (each component to a few `eps`
    /// relative). The DTH stepper then solves its energy equation in a cancellation-free form
    /// by default (`dth::EnergyResidual::Auto`).
    pub exact_divided_differences: bool,
    /// The implicit methods should solve their Newton systems with the structured solver
    /// ([`crate::structured`]) on [`Hamiltonian::hessian_pattern`] and
    /// [`Hamiltonian::hessian_nonzeros`], never forming a `D x D` matrix; `false` for the
    /// dense LU, the faster one for small `D`. Without a pattern it has no effect.
    /// `hamiltonian!` sets it per generated type from the measured crossover (see
    /// `docs/performance.md`).
    pub structured_newton: bool,
    /// The implementation is a regularization `K = g(z) (H + p_t)` in the extended phase
    /// space (with [`Flags::time_dependent`]): the flow's parameter is a fictitious time `s`
    /// (`dt/ds = g`), and the physical time is the `t` coordinate of the state, which the
    /// DTH stepper then reports as the time of each midpoint and vertex and ends a run on
    /// (`dth_symbolic::regularize`).
    pub regularized: bool,
}

impl Flags {
    /// All `false` (as `Flags::default()`, usable in constants).
    pub const fn new() -> Self {
        Flags {
            time_dependent: false,
            separable: false,
            psi_identically_zero: false,
            exact_divided_differences: false,
            structured_newton: false,
            regularized: false,
        }
    }

    /// With [`Flags::time_dependent`] set to `v`.
    pub const fn with_time_dependent(mut self, v: bool) -> Self {
        self.time_dependent = v;
        self
    }
    /// With [`Flags::regularized`] set to `v`.
    pub const fn with_regularized(mut self, v: bool) -> Self {
        self.regularized = v;
        self
    }
    /// With [`Flags::separable`] set to `v`.
    pub const fn with_separable(mut self, v: bool) -> Self {
        self.separable = v;
        self
    }
    /// With [`Flags::psi_identically_zero`] set to `v`.
    pub const fn with_psi_identically_zero(mut self, v: bool) -> Self {
        self.psi_identically_zero = v;
        self
    }
    /// With [`Flags::exact_divided_differences`] set to `v`.
    pub const fn with_exact_divided_differences(mut self, v: bool) -> Self {
        self.exact_divided_differences = v;
        self
    }
    /// With [`Flags::structured_newton`] set to `v`.
    pub const fn with_structured_newton(mut self, v: bool) -> Self {
        self.structured_newton = v;
        self
    }
}

/// [`Flags`] known when the program is compiled, for code that needs them before it has a
/// value (a catalogue registering a type, a compile-time assertion). `hamiltonian!` implements
/// it for every type it generates, and their [`Hamiltonian::flags`] returns the same; a
/// runtime Hamiltonian, whose flags come from its text, does not.
pub trait ConstFlags {
    /// The flags.
    const FLAGS: Flags;
}

/// Value, gradient, Hessian and Psi of a Hamiltonian at one point, computed together.
#[derive(Clone, Debug, PartialEq)]
pub struct Derivatives<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// `H(z)`.
    pub value: f64,
    /// `grad H(z)`.
    pub gradient: OVector<f64, D>,
    /// `Hess H(z)` (symmetric).
    pub hessian: OMatrix<f64, D, D>,
    /// `Psi(z) = (J grad H)^T Hess H (J grad H)`.
    pub psi: f64,
}

impl<D: Dim> Derivatives<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Zeros of dimension `d`: storage for [`Hamiltonian::derivatives_into`].
    pub fn zeros(d: D) -> Self {
        Derivatives {
            value: 0.0,
            gradient: zeros(d),
            hessian: zeros_matrix(d),
            psi: 0.0,
        }
    }
}

/// Copy for fixed sizes (the by-value code of `Const<N>` callers keeps working).
impl<const N: usize> Copy for Derivatives<nalgebra::Const<N>> {}

/// A Hamiltonian `H(z)` on a phase space of dimension `D = 2n`, `z = (q1..qn, p1..pn)`.
///
/// `hamiltonian!` generates implementations with exact symbolic derivatives; hand-written
/// implementations must provide [`dim`](Self::dim), `value`, `gradient_into` and
/// `hessian_into` and may rely on the defaults for the rest (see the module docs for an
/// example). Every output is written into the caller's storage, so that a stepper over a
/// `Dyn` dimension allocates its buffers once; the by-value forms ([`gradient`](Self::gradient),
/// [`hessian`](Self::hessian), [`derivatives`](Self::derivatives), ...) are conveniences over
/// them.
///
/// A time-dependent Hamiltonian `H(t, q, p)` implements this trait on the extended phase space
/// of Shibberu (1998), Theorem 1: `z = (q1..qn, t, p1..pn, p_t)`, `D = 2n + 2`, and
/// `value` returns `calH = p_t + H(t, q, p)`; it sets [`Flags::time_dependent`].
pub trait Hamiltonian<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// The dimension: `Const` for fixed-size types, `Dyn(d)` for one chosen at run time.
    fn dim(&self) -> D;

    /// What the Hamiltonian declares about itself (all `false` by default).
    fn flags(&self) -> Flags {
        Flags::default()
    }

    /// The nonzero entries of the upper triangle of the Hessian, `(i, j)` with `i <= j < D`,
    /// in the order [`Hamiltonian::hessian_nonzeros`] writes them; `None` (the default) when
    /// the structure is not declared. `hamiltonian!` emits it from the symbolic Hessian.
    fn hessian_pattern(&self) -> Option<&[(usize, usize)]> {
        None
    }

    /// `H(z)`.
    fn value(&self, z: &OVector<f64, D>) -> f64;
    /// `grad H(z)`, written into `out`.
    fn gradient_into(&self, z: &OVector<f64, D>, out: &mut OVector<f64, D>);
    /// `Hess H(z)`, symmetric, written into `out`.
    fn hessian_into(&self, z: &OVector<f64, D>, out: &mut OMatrix<f64, D, D>);

    /// `grad H(z)` by value (allocates for `Dyn`).
    #[track_caller]
    fn gradient(&self, z: &OVector<f64, D>) -> OVector<f64, D> {
        let mut out = zeros(self.dim());
        self.gradient_into(z, &mut out);
        out
    }

    /// `Hess H(z)` by value (allocates for `Dyn`).
    #[track_caller]
    fn hessian(&self, z: &OVector<f64, D>) -> OMatrix<f64, D, D> {
        let mut out = zeros_matrix(self.dim());
        self.hessian_into(z, &mut out);
        out
    }

    /// The Hessian's entries at [`Hamiltonian::hessian_pattern`], written into `values` in
    /// the pattern's order (`values` as long as the pattern; extra slots are left alone).
    ///
    /// The default reads them from [`Hamiltonian::hessian`] (a `D x D` matrix) and writes
    /// nothing without a pattern; `hamiltonian!` overrides it with a fused evaluation that
    /// computes only the nonzeros.
    fn hessian_nonzeros(&self, z: &OVector<f64, D>, values: &mut [f64]) {
        if let Some(pattern) = self.hessian_pattern() {
            let hessian = self.hessian(z);
            for (v, &(i, j)) in values.iter_mut().zip(pattern) {
                *v = hessian[(i, j)];
            }
        }
    }

    /// `Psi(z) = (J grad H)^T Hess H (J grad H)`.
    #[track_caller]
    fn psi(&self, z: &OVector<f64, D>) -> f64 {
        psi_from(&self.gradient(z), &self.hessian(z))
    }

    /// Value, gradient, Hessian and Psi in one evaluation, written into `out` (generated code
    /// shares every common subexpression between them).
    fn derivatives_into(&self, z: &OVector<f64, D>, out: &mut Derivatives<D>) {
        self.gradient_into(z, &mut out.gradient);
        self.hessian_into(z, &mut out.hessian);
        out.value = self.value(z);
        out.psi = psi_from(&out.gradient, &out.hessian);
    }

    /// [`derivatives_into`](Self::derivatives_into) by value (allocates for `Dyn`).
    #[track_caller]
    fn derivatives(&self, z: &OVector<f64, D>) -> Derivatives<D> {
        let mut out = Derivatives::zeros(self.dim());
        self.derivatives_into(z, &mut out);
        out
    }

    /// A discrete gradient `gbar(z0, z1)`, written into `out`: `gbar . (z1 - z0) = H(z1) -
    /// H(z0)` and `gbar(z, z) = grad H(z)`.
    ///
    /// The default is Gonzalez's midpoint discrete gradient, which computes `H(z1) - H(z0)` as
    /// a plain difference (cancellation when `z1` is close to `z0`). Types generated by
    /// `hamiltonian!` override it with exact divided differences of `H`, free of cancellation
    /// and symmetric in `z0`, `z1`.
    fn discrete_gradient_into(
        &self,
        z0: &OVector<f64, D>,
        z1: &OVector<f64, D>,
        out: &mut OVector<f64, D>,
    ) {
        let mid = (z0 + z1) * 0.5;
        self.gradient_into(&mid, out);
        let d = z1 - z0;
        let dd = d.dot(&d);
        if dd == 0.0 {
            return;
        }
        let defect = self.value(z1) - self.value(z0) - out.dot(&d);
        out.axpy(defect / dd, &d, 1.0);
    }

    /// [`discrete_gradient_into`](Self::discrete_gradient_into) by value.
    #[track_caller]
    fn discrete_gradient(&self, z0: &OVector<f64, D>, z1: &OVector<f64, D>) -> OVector<f64, D> {
        let mut out = zeros(self.dim());
        self.discrete_gradient_into(z0, z1, &mut out);
        out
    }

    /// The trapezoid defect of the discrete gradient,
    /// `t(z0, z1) = grad H(z0) + grad H(z1) - 2 gbar(z0, z1)`, which is `O(|z1 - z0|^2)`,
    /// written into `out`.
    ///
    /// The DTH stepper's cancellation-free energy residual needs it to an absolute error of a
    /// few `eps |grad H|` times `|z1 - z0|` / (the scale of `z`), i.e. without the cancellation
    /// of its plain form, whose absolute error `eps |grad H|` does not shrink with the step (with
    /// it, `lambda`'s error grows like `eps / dtau`). Implementations that set
    /// [`Flags::exact_divided_differences`] override it together with
    /// [`Hamiltonian::discrete_gradient_into`], consistently with it.
    fn discrete_gradient_defect_into(
        &self,
        z0: &OVector<f64, D>,
        z1: &OVector<f64, D>,
        gbar: &OVector<f64, D>,
        out: &mut OVector<f64, D>,
    ) {
        self.gradient_into(z0, out);
        *out += self.gradient(z1);
        out.axpy(-2.0, gbar, 1.0);
    }

    /// [`discrete_gradient_defect_into`](Self::discrete_gradient_defect_into) by value.
    #[track_caller]
    fn discrete_gradient_defect(
        &self,
        z0: &OVector<f64, D>,
        z1: &OVector<f64, D>,
        gbar: &OVector<f64, D>,
    ) -> OVector<f64, D> {
        let mut out = zeros(self.dim());
        self.discrete_gradient_defect_into(z0, z1, gbar, &mut out);
        out
    }

    /// `H(z1) - H(z0)`.
    ///
    /// The default is the plain difference, whose absolute error is about `eps |H|` however
    /// close `z1` is to `z0`. Generated code overrides it with exact divided differences
    /// (`discrete_gradient(z0, z1) . (z1 - z0)`, computed without cancellation), accurate to a
    /// few `eps` of `|grad H| |z1 - z0|`.
    fn energy_difference(&self, z0: &OVector<f64, D>, z1: &OVector<f64, D>) -> f64 {
        self.value(z1) - self.value(z0)
    }

    /// `grad H` at the double-double point `hi + lo` (each `|lo_i|` at most half an ulp of
    /// `hi_i`), in double-double arithmetic, written as `out_hi + out_lo`; `false` (and
    /// nothing written) where it is not provided, the default.
    ///
    /// A regularized DTH run started in double-double ([`Dth::with_low`](crate::dth::Dth::with_low),
    /// `solve`'s `start_low`) solves its steps with it beyond double precision:
    /// `hamiltonian!` types with `#[regularize(...)]` provide it.
    fn gradient_double_double_into(
        &self,
        z: (&OVector<f64, D>, &OVector<f64, D>),
        out: (&mut OVector<f64, D>, &mut OVector<f64, D>),
    ) -> bool {
        let _ = (z, out);
        false
    }
}

/// A shared reference is the Hamiltonian it points to: one `H` (a text compiled at run time
/// once, a large generated type) can drive several steppers or methods without being cloned or
/// compiled again. Every method forwards to `H`'s own, so its overrides (fused evaluation,
/// exact divided differences, Hessian pattern) are the ones used, and a stepper on `&H`
/// computes what one on `H` does, bit for bit.
///
/// ```
/// use dth_core::dth::{Dth, DthOptions};
/// use dth_core::{nalgebra::Vector4, systems::Kepler};
/// let kepler = Kepler::thesis(); // one Hamiltonian, two steppers
/// let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
/// let mut coarse = Dth::new(&kepler, z0, DthOptions::thesis_kepler())?;
/// let mut fine = Dth::new(&kepler, z0, DthOptions::new(0.01)?)?;
/// coarse.advance(10)?;
/// fine.advance(10)?;
/// let mut owned = Dth::new(Kepler::thesis(), z0, DthOptions::thesis_kepler())?;
/// owned.advance(10)?;
/// assert_eq!(coarse.zbar(), owned.zbar());
/// # Ok::<(), dth_core::Error>(())
/// ```
impl<D: Dim, H: Hamiltonian<D> + ?Sized> Hamiltonian<D> for &H
where
    DefaultAllocator: Alloc<D>,
{
    fn dim(&self) -> D {
        (**self).dim()
    }
    fn flags(&self) -> Flags {
        (**self).flags()
    }
    fn hessian_pattern(&self) -> Option<&[(usize, usize)]> {
        (**self).hessian_pattern()
    }
    fn value(&self, z: &OVector<f64, D>) -> f64 {
        (**self).value(z)
    }
    fn gradient_into(&self, z: &OVector<f64, D>, out: &mut OVector<f64, D>) {
        (**self).gradient_into(z, out);
    }
    fn hessian_into(&self, z: &OVector<f64, D>, out: &mut OMatrix<f64, D, D>) {
        (**self).hessian_into(z, out);
    }
    fn gradient(&self, z: &OVector<f64, D>) -> OVector<f64, D> {
        (**self).gradient(z)
    }
    fn hessian(&self, z: &OVector<f64, D>) -> OMatrix<f64, D, D> {
        (**self).hessian(z)
    }
    fn hessian_nonzeros(&self, z: &OVector<f64, D>, values: &mut [f64]) {
        (**self).hessian_nonzeros(z, values);
    }
    fn psi(&self, z: &OVector<f64, D>) -> f64 {
        (**self).psi(z)
    }
    fn derivatives_into(&self, z: &OVector<f64, D>, out: &mut Derivatives<D>) {
        (**self).derivatives_into(z, out);
    }
    fn derivatives(&self, z: &OVector<f64, D>) -> Derivatives<D> {
        (**self).derivatives(z)
    }
    fn discrete_gradient_into(
        &self,
        z0: &OVector<f64, D>,
        z1: &OVector<f64, D>,
        out: &mut OVector<f64, D>,
    ) {
        (**self).discrete_gradient_into(z0, z1, out);
    }
    fn discrete_gradient(&self, z0: &OVector<f64, D>, z1: &OVector<f64, D>) -> OVector<f64, D> {
        (**self).discrete_gradient(z0, z1)
    }
    fn discrete_gradient_defect_into(
        &self,
        z0: &OVector<f64, D>,
        z1: &OVector<f64, D>,
        gbar: &OVector<f64, D>,
        out: &mut OVector<f64, D>,
    ) {
        (**self).discrete_gradient_defect_into(z0, z1, gbar, out);
    }
    fn discrete_gradient_defect(
        &self,
        z0: &OVector<f64, D>,
        z1: &OVector<f64, D>,
        gbar: &OVector<f64, D>,
    ) -> OVector<f64, D> {
        (**self).discrete_gradient_defect(z0, z1, gbar)
    }
    fn energy_difference(&self, z0: &OVector<f64, D>, z1: &OVector<f64, D>) -> f64 {
        (**self).energy_difference(z0, z1)
    }
    fn gradient_double_double_into(
        &self,
        z: (&OVector<f64, D>, &OVector<f64, D>),
        out: (&mut OVector<f64, D>, &mut OVector<f64, D>),
    ) -> bool {
        (**self).gradient_double_double_into(z, out)
    }
}

/// `J v` for `J = [[0, I], [-I, 0]]`: `(v_p, -v_q)` (`v` of even length).
///
/// ```
/// use dth_core::{j_times, nalgebra::Vector4};
/// let v = Vector4::new(1.0, 2.0, 3.0, 4.0);
/// assert_eq!(j_times(&v), Vector4::new(3.0, 4.0, -1.0, -2.0));
/// ```
pub fn j_times<D: Dim>(v: &OVector<f64, D>) -> OVector<f64, D>
where
    DefaultAllocator: Alloc<D>,
{
    let mut out = v.clone();
    j_times_into(v, &mut out);
    out
}

/// `J v` written into `out` (both of the same even length).
pub fn j_times_into<D: Dim>(v: &OVector<f64, D>, out: &mut OVector<f64, D>)
where
    DefaultAllocator: Alloc<D>,
{
    let n = v.len() / 2;
    for i in 0..n {
        out[i] = v[i + n];
        out[i + n] = -v[i];
    }
}

/// `Psi = (J g)^T Hess (J g)` from a gradient and a Hessian, without allocating:
/// `sum_ij (Jg)_i H_ij (Jg)_j`.
pub fn psi_from<D: Dim>(gradient: &OVector<f64, D>, hessian: &OMatrix<f64, D, D>) -> f64
where
    DefaultAllocator: Alloc<D>,
{
    let n = gradient.len() / 2;
    let w = |i: usize| {
        if i < n {
            gradient[i + n]
        } else {
            -gradient[i - n]
        }
    };
    let d = gradient.len();
    let mut sum = 0.0;
    for j in 0..d {
        let mut col = 0.0;
        for i in 0..d {
            col += w(i) * hessian[(i, j)];
        }
        sum += col * w(j);
    }
    sum
}
