//! `hamiltonian!` on lattices written once: the FPUT-alpha chain of 8 particles from a
//! one-line sum, emitted as loops over the sites, and the same sum with a term outside the
//! sums (built site by site), against the chain written out term by term (`tests/chains/`):
//! every method of the trait to roundoff, and the Hessian pattern the structured Newton reads.
//! Then the chain of 4096 particles (`D = 8192`), which only the loops reach.

use dth::nalgebra::Const;
use dth::nalgebra::SVector;
use dth::Hamiltonian;

include!("chains/fput_alpha_8.rs");

dth::hamiltonian! {
    /// FPUT-alpha, `alpha = 1/4`, fixed ends, written once: a sum of sums, emitted as loops.
    pub struct FputSum8 { alpha: f64 } =
        sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3)
        where N = 8, q[0] = q[N+1] = 0
}

dth::hamiltonian! {
    /// The same chain with the first bond outside the sums: built site by site.
    pub struct FputMixed8 = sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2 + (q[i+1] - q[i])^3/12)
        + (q[1] - q[0])^2/2 + (q[1] - q[0])^3/12
        where N = 8, q[0] = q[N+1] = 0
}

dth::hamiltonian! {
    /// FPUT-alpha of 4096 particles.
    pub struct Fput4096 { alpha: f64 } =
        sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3)
        where N = 4096, q[0] = q[N+1] = 0
}

/// A deterministic point in `[-0.5, 0.5)^16`.
fn point(seed: u64) -> SVector<f64, 16> {
    let mut s = seed;
    SVector::from_fn(|_, _| {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    })
}

/// Roundoff: the two texts add the same 25 terms (each below 1 on these points) in different
/// orders, so results differ by a few `eps` times their magnitude sum.
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 64.0 * f64::EPSILON * (1.0 + a.abs().max(b.abs()))
}

/// Every method of `looped` equals the written-out chain's to roundoff at a few points.
fn equals_written_out<H: Hamiltonian<Const<16>>>(looped: &H) {
    let written = FputAlpha8;
    let mut pattern = looped.hessian_pattern().unwrap().to_vec();
    let mut expected = written.hessian_pattern().unwrap().to_vec();
    pattern.sort_unstable();
    expected.sort_unstable();
    assert_eq!(pattern, expected);
    assert_eq!(
        looped.flags().structured_newton,
        written.flags().structured_newton
    );
    assert_eq!(looped.flags().separable, written.flags().separable);
    for seed in 1..6 {
        let (z0, z1) = (point(seed), point(seed + 50));
        assert!(close(looped.value(&z0), written.value(&z0)));
        assert!(close(looped.psi(&z0), written.psi(&z0)));
        let (a, b) = (looped.derivatives(&z0), written.derivatives(&z0));
        assert!(close(a.value, b.value) && close(a.psi, b.psi));
        assert!(a
            .gradient
            .iter()
            .zip(b.gradient.iter())
            .all(|(x, y)| close(*x, *y)));
        assert!(a
            .hessian
            .iter()
            .zip(b.hessian.iter())
            .all(|(x, y)| close(*x, *y)));
        assert!(close(
            looped.energy_difference(&z0, &z1),
            written.energy_difference(&z0, &z1)
        ));
        let (ga, gb) = (
            looped.discrete_gradient(&z0, &z1),
            written.discrete_gradient(&z0, &z1),
        );
        assert!(ga.iter().zip(gb.iter()).all(|(x, y)| close(*x, *y)));
        let (da, db) = (
            looped.discrete_gradient_defect(&z0, &z1, &ga),
            written.discrete_gradient_defect(&z0, &z1, &gb),
        );
        assert!(da.iter().zip(db.iter()).all(|(x, y)| close(*x, *y)));
        // The fused nonzeros, entry by entry of the type's own pattern.
        let mut values = vec![0.0; looped.hessian_pattern().unwrap().len()];
        looped.hessian_nonzeros(&z0, &mut values);
        let dense = written.hessian(&z0);
        for (v, &(i, j)) in values.iter().zip(looped.hessian_pattern().unwrap()) {
            assert!(close(*v, dense[(i, j)]));
        }
    }
}

#[test]
fn looped_fput_equals_the_written_out_chain() {
    equals_written_out(&FputSum8 { alpha: 0.25 });
}

#[test]
fn site_by_site_fput_equals_the_written_out_chain() {
    equals_written_out(&FputMixed8);
}

#[test]
fn the_chain_of_4096_compiles_and_agrees_with_the_engine() {
    const D: usize = 8192;
    let h = Fput4096 { alpha: 0.25 };
    let pattern = Hamiltonian::<Const<D>>::hessian_pattern(&h).unwrap();
    assert_eq!(pattern.len(), 3 * 4096 - 1);
    assert!(Hamiltonian::<Const<D>>::flags(&h).structured_newton);
    // The engine's looped interpreter on the same text.
    let engine = dth_symbolic::looped::compile(
        "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3) \
         where N = 4096, q[0] = q[N+1] = 0",
        &["alpha"],
    )
    .unwrap();
    let z: Box<SVector<f64, D>> = Box::new(SVector::from_fn(|i, _| {
        ((i * 7919) % 1000) as f64 / 2000.0 - 0.25
    }));
    let e = engine.eval(z.as_slice(), &[0.25]).unwrap();
    assert!(close(h.value(&z), e.value));
    let g = Box::new(h.gradient(&z));
    assert!(g.iter().zip(&e.gradient).all(|(a, b)| close(*a, *b)));
    let mut values = vec![0.0; pattern.len()];
    h.hessian_nonzeros(&z, &mut values);
    let mut entries: Vec<((usize, usize), f64)> = pattern
        .iter()
        .copied()
        .zip(values.iter().copied())
        .collect();
    entries.sort_by_key(|&(ij, _)| ij);
    assert!(entries
        .iter()
        .zip(&e.hessian)
        .all(|(&((i, j), v), &(a, b, w))| (i, j) == (a, b) && close(v, w)));
    // Psi sums 3N - 1 terms `v w_a w_b` (w = J grad H), which cancel: the type adds them in
    // its pattern's order (by diagonal), the engine row by row. Each recursive sum is within
    // (n - 1) eps sum |terms| of the exact one, so the two within twice that (here ~3e-9 on
    // Psi ~ 280; the orders differ by ~1e-11).
    let w = |k: usize| if k < 4096 { g[k + 4096] } else { -g[k - 4096] };
    let terms: f64 = entries
        .iter()
        .map(|&((i, j), v)| if i == j { 1.0 } else { 2.0 } * (v * w(i) * w(j)).abs())
        .sum();
    let bound = 2.0 * entries.len() as f64 * f64::EPSILON * terms;
    assert!(
        (h.psi(&z) - e.psi).abs() <= bound,
        "{} vs {}",
        h.psi(&z),
        e.psi
    );
}

#[test]
fn all_pairs_and_periodic_sums_in_the_expression_form() {
    // Calogero-Moser: all pairs, inverse-square repulsion, in a harmonic trap.
    let calogero = dth::hamiltonian!(
        sum(i = 1..N, p[i]^2/2 + q[i]^2/2) + sum(1 <= i < j <= N, 1/(q[i] - q[j])^2) where N = 3
    );
    let written = dth::hamiltonian!(
        p1 ^ 2 / 2 + q1
            ^ 2 / 2 + p2
            ^ 2 / 2 + q2
            ^ 2 / 2 + p3
            ^ 2 / 2 + q3
            ^ 2 / 2 + 1 / (q1 - q2)
            ^ 2 + 1 / (q1 - q3)
            ^ 2 + 1 / (q2 - q3)
            ^ 2
    );
    let z = SVector::<f64, 6>::new(-1.0, 0.1, 1.3, 0.2, -0.3, 0.4);
    assert!(close(calogero.value(&z), written.value(&z)));
    assert!(close(calogero.psi(&z), written.psi(&z)));
    // Periodic Toda ring of 4.
    let ring = dth::hamiltonian!(sum(i = 1..4, p[i]^2/2 + exp(q[i] - q[i+1])) where q[5] = q[1]);
    let z = SVector::<f64, 8>::from_fn(|i, _| 0.1 * i as f64 - 0.3);
    let e: f64 = (0..4)
        .map(|i| z[4 + i] * z[4 + i] / 2.0 + (z[i] - z[(i + 1) % 4]).exp())
        .sum();
    assert!(close(ring.value(&z), e));
}

#[test]
fn the_structured_newton_steps_the_looped_chain_as_the_written_out_one() {
    use dth::methods::{DiscreteGradient, ImplicitMidpoint, OneStepMethod};
    let (looped, written) = (FputSum8 { alpha: 0.25 }, FputAlpha8);
    let (mut a, mut b) = (point(9), point(9));
    let (mut ma, mut mb) = (ImplicitMidpoint::new(), ImplicitMidpoint::new());
    let (mut da, mut db) = (DiscreteGradient::new(), DiscreteGradient::new());
    for _ in 0..5 {
        a = ma.step(&looped, &a, 0.1).expect("midpoint, loops");
        b = mb.step(&written, &b, 0.1).expect("midpoint, written out");
        a = da.step(&looped, &a, 0.1).expect("discrete gradient, loops");
        b = db
            .step(&written, &b, 0.1)
            .expect("discrete gradient, written out");
    }
    // Newton converges to roundoff on both; the two evaluate the same terms in different
    // orders, so the states differ by the Newton tolerance times a few steps' growth.
    assert!((a - b).amax() < 1e-12, "{}", (a - b).amax());
}

#[test]
fn the_chain_of_4096_takes_discrete_gradient_steps_at_constant_energy() {
    use dth::methods::{DiscreteGradient, OneStepMethod};
    const D: usize = 8192;
    let run = || {
        let h = Fput4096 { alpha: 0.25 };
        let mut z: Box<SVector<f64, D>> = Box::new(SVector::from_fn(|i, _| {
            if i < 4096 {
                0.1 * ((i as f64) * 0.01).sin()
            } else {
                0.0
            }
        }));
        let e0 = h.value(&z);
        let mut dg = DiscreteGradient::new();
        let mut drift = 0.0f64;
        for _ in 0..3 {
            *z = dg.step(&h, &z, 0.05).expect("discrete gradient step");
            drift = drift.max((h.value(&z) - e0).abs());
        }
        (e0, drift)
    };
    let (e0, drift) = std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(run)
        .expect("spawn")
        .join()
        .expect("the run");
    // The discrete gradient conserves H exactly up to the Newton remainder and the rounding of
    // H, a sum of 8192 terms each below 1e-2 (|q| <= 0.1): below 8192 eps * 1e-2 ~ 2e-14 per
    // evaluation; 1e-12 leaves room for the Newton remainder.
    assert!(drift <= 1e-12 * (1.0 + e0), "drift {drift} at H = {e0}");
}

dth::hamiltonian! {
    /// FPUT-alpha of 1024 particles (`D = 2048`), written once: the size at which the DTH
    /// energy guarantee is checked on a looped lattice.
    #[derive(Clone, Copy)]
    pub struct Fput1024 { alpha: f64 } =
        sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3)
        where N = 1024, q[0] = q[N+1] = 0
}

/// DTH on the looped chain of 1024 particles: 10^4 steps on the structured Newton (the
/// emitted loops give it value, gradient, Psi and the Hessian's nonzeros; no `D x D` matrix),
/// with `H` at every midpoint equal to `H(zbar_0)` to roundoff. The scale of that roundoff is
/// the size of the terms `H` sums, `max(|H|, sum |z_i dH/dz_i|)`; the energy equation is solved
/// to a few `eps` of it per step and the midpoint values do not accumulate error (each is
/// measured against `H(zbar_0)` directly), so the bound is a small multiple of `eps` times it,
/// as for the written-out 512-particle chain.
#[test]
fn dth_keeps_the_energy_of_the_looped_1024_particle_chain() {
    const N: usize = 1024;
    const D: usize = 2 * N;
    const STEPS: usize = 10_000;
    let h = Fput1024 { alpha: 0.25 };
    assert!(Hamiltonian::<Const<D>>::flags(&h).structured_newton);
    // Mode 1 of the chain, a shorter wave on top and a momentum pattern: every bond stretched.
    let z0 = SVector::<f64, D>::from_fn(|k, _| {
        let i = (k % N + 1) as f64;
        if k < N {
            0.5 * (std::f64::consts::PI * i / (N + 1) as f64).sin() + 0.05 * (7.0 * i).sin()
        } else {
            0.1 * (3.0 * i).cos()
        }
    });
    let options = dth::dth::DthOptions::new(0.1).expect("dtau");
    let mut dth = dth::dth::Dth::new(h, z0, options).expect("start");
    let e0 = h.value(&z0);
    let scale = e0.abs().max(z0.component_mul(&h.gradient(&z0)).abs().sum());
    let mut drift = 0.0f64;
    for _ in 0..STEPS {
        dth.step().expect("DTH step");
        drift = drift.max((h.value(dth.zbar()) - e0).abs());
    }
    let t = dth.tbar();
    eprintln!("looped 1024-particle chain, DTH to t = {t}: energy error {drift:e}, terms {scale}");
    assert!(t > 0.05 * STEPS as f64, "t = {t}");
    assert!(
        drift <= 16.0 * f64::EPSILON * scale,
        "energy error {drift:e}, terms of H {scale}"
    );
}

/// A user's own inherent items with ordinary names beside a looped lattice: the macro's
/// helpers on the type are hidden `__dth_` names, so these do not collide with them.
impl FputSum8 {
    const RUNS: usize = 3;
    const STRUCTURED_NEWTON: &'static str = "mine";
    fn pattern(&self) -> f64 {
        self.alpha
    }
}

#[test]
fn a_users_inherent_items_do_not_collide_with_the_looped_lattices() {
    let h = FputSum8 { alpha: 0.25 };
    assert_eq!(FputSum8::RUNS, 3);
    assert_eq!(FputSum8::STRUCTURED_NEWTON, "mine");
    assert_eq!(h.pattern(), 0.25);
    // The trait's pattern is still the lattice's upper triangle: 8 diagonal q entries, 7
    // pairs of neighbours, 8 p entries.
    assert_eq!(h.hessian_pattern().map(<[_]>::len), Some(8 + 7 + 8));
}
