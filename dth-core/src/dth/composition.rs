//! [`Composition`]: DTH of order 4, 6 and 8 by symmetric composition of DTH steps in `tau`.

// The coefficients are written with the digits their sources print (26 for Kahan and Li, 40
// for Suzuki's closed form), so that they can be checked against them; the compiler rounds
// each to the nearest f64.
#![allow(clippy::excessive_precision)]

/// A symmetric composition of DTH steps: the order of the method and its coefficients
/// `gamma_1 .. gamma_s` (each composed step of size `dtau` is the DTH steps
/// `gamma_1 dtau, ..., gamma_s dtau` in turn).
///
/// A DTH step is a one-step map `Phi_h: (zbar_k, lambda_k) -> (zbar_{k+1}, lambda_{k+1})` (with
/// the midpoint time carried along by `tbar_{k+1} = tbar_k + h (lambda_k + lambda_{k+1}) / 2`).
/// It is **symmetric**, `Phi_{-h}(Phi_h(x)) = x` (exchanging `(k, h)` with `(k + 1, -h)` leaves
/// the step equations unchanged), of order 2 as an approximation of the `tau`-flow of
/// `z' = lambda J grad H(z)`, `lambda^3 Psi(z) = const` (the law of time, in the limit
/// `h -> 0`), and it keeps `H(zbar) = H(zbar_0)` exactly for every `h`, negative included. A
/// symmetric composition
///
/// ```text
/// Psi_h = Phi_{gamma_s h} o ... o Phi_{gamma_2 h} o Phi_{gamma_1 h},     gamma_i = gamma_{s+1-i}
/// ```
///
/// of such a map is again symmetric, and with the coefficients below it has order 4, 6 or 8
/// (Hairer, Lubich, Wanner, *Geometric Numerical Integration*, 2nd ed., Sections II.4 and V.3).
/// Every sub-step is a DTH step, so energy stays exact at every midpoint, the intermediate
/// ones included. Some `gamma_i` are negative: those sub-steps run backwards in `tau` and in
/// time (`dt = lambda gamma_i h < 0` with `lambda > 0`).
///
/// What is lost above order 2: the midpoints of one composed step lie on segments of unequal
/// halves (the half-lengths `gamma_i h / 2` change between sub-steps), so the quadratic
/// invariants that DTH keeps at its vertices for order 2 (paper Theorem 7) are no longer exact
/// across a composed step; each composed step's end midpoint still has a symmetric segment
/// (`gamma_1 = gamma_s`), whose two ends are the vertices a trajectory reports.
///
/// The coefficients, chosen for DTH among the published symmetric compositions: the largest
/// sub-step is at most `0.8 h` in every one (the triple jump's middle step is `-1.70 h`, and a
/// DTH step of that size needs far more Newton iterations and breaks down sooner), and among
/// compositions of their order they have the smallest error constants known (Hairer, Lubich,
/// Wanner, Section V.3.2).
///
/// - order 4: Suzuki's five-stage fractal, `gamma_1 = gamma_2 = gamma_4 = gamma_5 =
///   1/(4 - 4^(1/3))`, `gamma_3 = 1 - 4 gamma_1` (M. Suzuki, *Fractal decomposition of
///   exponential operators*, Phys. Lett. A 146 (1990) 319-323; Hairer, Lubich, Wanner eq. II.4.5);
/// - order 6: Kahan and Li's `s9odr6a`, nine stages;
/// - order 8: Kahan and Li's `s17odr8a`, seventeen stages (W. Kahan, R.-C. Li, *Composition
///   constants for raising the orders of unconventional schemes for ordinary differential
///   equations*, Math. Comp. 66 (1997) 1089-1099; the 26-digit values as printed in Hairer,
///   Lubich, Wanner, Section V.3.2).
///
/// The theory, and what it means for negative sub-steps, is in `docs/theory.md#composition`.
///
/// The unit tests of `dth-core/src/dth/composition.rs` check the order conditions: `sum gamma_i = 1` and
/// `sum gamma_i^(2j+1) = 0` to roundoff, and the local error of the composition of a generic
/// symmetric second-order map (`exp(h A + h^3 B + h^5 C + h^7 E)` with random matrices, whose
/// commutators stand for the free Lie algebra) against `exp(h A)`, which falls like
/// `h^(p+1)` exactly when every order condition up to `p` holds.
///
/// ```
/// use dth_core::dth::Composition;
/// let c = Composition::from_order(8).unwrap();
/// assert_eq!((c.order(), c.stages()), (8, 17));
/// let sum: f64 = c.coefficients().iter().sum();
/// assert!((sum - 1.0).abs() < 1e-15);
/// assert!(Composition::from_order(5).is_none());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Composition {
    /// Plain DTH: one step of `dtau` (order 2). The default.
    #[default]
    Order2,
    /// Suzuki's five-stage composition (order 4).
    Suzuki4,
    /// Kahan and Li's nine-stage composition `s9odr6a` (order 6).
    KahanLi6,
    /// Kahan and Li's seventeen-stage composition `s17odr8a` (order 8).
    KahanLi8,
}

/// `1 / (4 - 4^(1/3))` (40 digits: 0.4144907717943757371423540628607614957117).
const SUZUKI_OUTER: f64 = 0.414_490_771_794_375_737_142_354_062_860_761_5;
/// `1 - 4 / (4 - 4^(1/3))` (40 digits: -0.657963087177502948569416251443045982847).
const SUZUKI_MIDDLE: f64 = -0.657_963_087_177_502_948_569_416_251_443_046;

const ORDER2: [f64; 1] = [1.0];

const SUZUKI4: [f64; 5] = [
    SUZUKI_OUTER,
    SUZUKI_OUTER,
    SUZUKI_MIDDLE,
    SUZUKI_OUTER,
    SUZUKI_OUTER,
];

/// Kahan and Li (1997), `s9odr6a`; Hairer, Lubich, Wanner, Section V.3.2.
const KAHAN_LI6: [f64; 9] = [
    0.392_161_444_007_314_139_279_250_56,
    0.332_599_136_789_359_438_599_748_64,
    -0.706_246_172_557_639_359_809_964_82,
    0.082_213_596_293_550_800_231_490_45,
    0.798_543_990_934_829_963_398_950_35,
    0.082_213_596_293_550_800_231_490_45,
    -0.706_246_172_557_639_359_809_964_82,
    0.332_599_136_789_359_438_599_748_64,
    0.392_161_444_007_314_139_279_250_56,
];

/// Kahan and Li (1997), `s17odr8a`; Hairer, Lubich, Wanner, Section V.3.2.
const KAHAN_LI8: [f64; 17] = [
    0.130_202_483_088_890_080_878_817_63,
    0.561_162_981_775_108_384_561_964_41,
    -0.389_474_962_644_847_286_408_078_60,
    0.158_841_906_555_155_600_896_210_75,
    -0.395_903_894_133_237_577_336_231_54,
    0.184_539_640_978_315_707_091_832_54,
    0.258_374_387_686_322_047_293_979_11,
    0.295_011_723_609_310_298_870_966_24,
    -0.605_508_533_830_034_511_698_921_08,
    0.295_011_723_609_310_298_870_966_24,
    0.258_374_387_686_322_047_293_979_11,
    0.184_539_640_978_315_707_091_832_54,
    -0.395_903_894_133_237_577_336_231_54,
    0.158_841_906_555_155_600_896_210_75,
    -0.389_474_962_644_847_286_408_078_60,
    0.561_162_981_775_108_384_561_964_41,
    0.130_202_483_088_890_080_878_817_63,
];

impl Composition {
    /// Every composition, by order.
    pub const ALL: [Composition; 4] = [
        Composition::Order2,
        Composition::Suzuki4,
        Composition::KahanLi6,
        Composition::KahanLi8,
    ];

    /// The orders offered: 2, 4, 6, 8.
    pub const ORDERS: [u32; 4] = [2, 4, 6, 8];

    /// The composition of order `order` (2, 4, 6 or 8), if offered.
    pub fn from_order(order: u32) -> Option<Composition> {
        Composition::ALL.into_iter().find(|c| c.order() == order)
    }

    /// Its order.
    pub const fn order(self) -> u32 {
        match self {
            Composition::Order2 => 2,
            Composition::Suzuki4 => 4,
            Composition::KahanLi6 => 6,
            Composition::KahanLi8 => 8,
        }
    }

    /// Its coefficients `gamma_1 .. gamma_s` (symmetric: `gamma_i = gamma_{s+1-i}`; they sum
    /// to 1 to roundoff).
    pub const fn coefficients(self) -> &'static [f64] {
        match self {
            Composition::Order2 => &ORDER2,
            Composition::Suzuki4 => &SUZUKI4,
            Composition::KahanLi6 => &KAHAN_LI6,
            Composition::KahanLi8 => &KAHAN_LI8,
        }
    }

    /// Number of DTH steps per composed step.
    pub const fn stages(self) -> usize {
        self.coefficients().len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SMatrix;

    type M = SMatrix<f64, 6, 6>;

    #[test]
    fn coefficients_are_symmetric_and_sum_to_one() {
        for c in Composition::ALL {
            let g = c.coefficients();
            for i in 0..g.len() {
                assert_eq!(g[i], g[g.len() - 1 - i], "{c:?}");
            }
            let sum: f64 = g.iter().sum();
            // A sum of at most 17 numbers below 1 in size: a few eps.
            assert!((sum - 1.0).abs() <= 8.0 * f64::EPSILON, "{c:?}: {sum:e}");
            if c != Composition::Order2 {
                assert!(
                    g.iter().all(|x| x.abs() < 0.8),
                    "{c:?}: a sub-step above 0.8 dtau"
                );
            }
        }
    }

    /// `sum gamma_i^(2j+1) = 0` for `2j + 1 < p`: the order conditions of the terms
    /// `h^(2j+1) B_j` of the basic method's error that commute with nothing else.
    #[test]
    fn odd_power_sums_vanish_below_the_order() {
        for c in Composition::ALL {
            let g = c.coefficients();
            for power in (3..c.order() as i32).step_by(2) {
                let sum: f64 = g.iter().map(|x| x.powi(power)).sum();
                let size: f64 = g.iter().map(|x| x.abs().powi(power)).sum();
                // Roundoff of the published 26-digit values rounded to f64 and of the sum.
                assert!(
                    sum.abs() <= 16.0 * f64::EPSILON * size,
                    "{c:?}: sum gamma^{power} = {sum:e}"
                );
            }
            // ... and the next one does not vanish (the order is not higher by accident).
            let next = c.order() as i32 + 1;
            let sum: f64 = g.iter().map(|x| x.powi(next)).sum();
            assert!(sum.abs() > 1e-6, "{c:?}: sum gamma^{next} = {sum:e}");
        }
    }

    /// A pseudo-random matrix with entries in [-1, 1] (fixed seed, no dependency).
    fn matrix(seed: &mut u64) -> M {
        M::from_fn(|_, _| {
            *seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        })
    }

    /// Local error of the composition of `exp(h A + h^3 B + h^5 C + h^7 E)` (a generic
    /// symmetric map of order 2: its logarithm is odd in `h`) against `exp(h A)`.
    fn local_error(c: Composition, a: &M, b: &M, cc: &M, e: &M, h: f64) -> f64 {
        let mut product = M::identity();
        for &g in c.coefficients() {
            let s = g * h;
            let generator = a * s + b * s.powi(3) + cc * s.powi(5) + e * s.powi(7);
            product = generator.exp() * product;
        }
        (product - (a * h).exp()).norm()
    }

    /// The full order conditions (all commutators of the free Lie algebra up to degree p,
    /// e.g. `[A, [A, B]]` at order 6): the local error falls like `h^(p+1)`. Halving `h`
    /// divides it by `2^(p+1)`; measured where it is far above the roundoff of the matrix
    /// exponentials (about 1e-14) and in the asymptotic range.
    #[test]
    fn local_error_has_the_order_of_the_composition() {
        let mut seed = 7;
        let (a, b, cc, e) = (
            matrix(&mut seed) * 0.5,
            matrix(&mut seed) * 0.5,
            matrix(&mut seed) * 0.5,
            matrix(&mut seed) * 0.5,
        );
        for c in Composition::ALL {
            let p = c.order() as i32;
            // Order 8's error is below 1e-12 at h = 0.1: start higher.
            let h = if p == 8 { 0.4 } else { 0.2 };
            let (e1, e2) = (
                local_error(c, &a, &b, &cc, &e, h),
                local_error(c, &a, &b, &cc, &e, h / 2.0),
            );
            let observed = (e1 / e2).log2();
            println!(
                "{c:?}: local errors {e1:e}, {e2:e}: order {:.3}",
                observed - 1.0
            );
            assert!(e2 > 1e-11, "{c:?}: {e2:e} too close to roundoff");
            assert!(
                (observed - (p + 1) as f64).abs() < 0.3,
                "{c:?}: local errors {e1:e}, {e2:e}: observed local order {observed:.2}"
            );
        }
    }
}
