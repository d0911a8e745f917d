//! N-body systems from one line each, text and macro: a 3-D gravitating cluster of 64 bodies
//! and a Calogero-Moser system of 256 particles, their pair sums compiled once and looped
//! (`dth_symbolic::looped::nested`), stepped by DTH with the energy at every midpoint equal
//! to the first to roundoff; the text (the JIT, `Hamiltonian<Dyn>`) and the macro's type take
//! the same steps, bit for bit.

#![cfg(feature = "runtime")]

use dth::dth::{Dth, DthOptions};
use dth::nalgebra::{Const, DVector, SVector};
use dth::runtime::{Fixed, RuntimeHamiltonian};
use dth::Hamiltonian;
use dth_symbolic::sources::{calogero_moser, gravity_3d};

dth::hamiltonian! {
    /// 64 gravitating bodies in 3-D.
    #[derive(Clone, Copy)]
    struct Cluster64 =
        sum(i = 1..N, (p[3*i-2]^2 + p[3*i-1]^2 + p[3*i]^2)/2) - sum(1 <= i < j <= N,
        ((q[3*i-2] - q[3*j-2])^2 + (q[3*i-1] - q[3*j-1])^2 + (q[3*i] - q[3*j])^2)^(-1/2))
        where N = 64
}

dth::hamiltonian! {
    /// Calogero-Moser, 256 particles.
    #[derive(Clone, Copy)]
    struct Calogero256 { g: f64 } =
        sum(i = 1..N, p[i]^2/2) + g^2*sum(1 <= i < j <= N, (q[i] - q[j])^(-2)) where N = 256
}

/// A seeded number in `[-1, 1)`.
fn noise(s: &mut u64) -> f64 {
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    2.0 * ((*s >> 11) as f64 / (1u64 << 53) as f64) - 1.0
}

/// The cluster's start: 64 bodies on a 4 x 4 x 4 grid of spacing 1, moved by up to 0.1, with
/// velocities up to 0.1 in each direction.
fn cluster_start() -> Vec<f64> {
    let (n, mut s) = (64, 0x5eed_u64);
    let mut z = vec![0.0; 6 * n];
    for b in 0..n {
        let cell = [b % 4, (b / 4) % 4, b / 16];
        for (k, &c) in cell.iter().enumerate() {
            z[3 * b + k] = c as f64 + 0.1 * noise(&mut s);
            z[3 * n + 3 * b + k] = 0.1 * noise(&mut s);
        }
    }
    z
}

/// Calogero-Moser's start: particles at `i + 0.2 u`, momenta `0.3 u`.
fn calogero_start() -> Vec<f64> {
    let (n, mut s) = (256, 0xca10_u64);
    let mut z = vec![0.0; 2 * n];
    for i in 0..n {
        z[i] = i as f64 + 0.2 * noise(&mut s);
        z[n + i] = 0.3 * noise(&mut s);
    }
    z
}

/// DTH on `h` from `z0` for `steps` steps: the midpoints, and the largest `|H(zbar_k) -
/// H(zbar_0)|` against the scale of the terms `H` sums, `max(|H|, sum |z_i dH/dz_i|)`. The
/// energy equation is solved to a few `eps` of that scale each step and each midpoint is
/// measured against `H(zbar_0)` directly, so the error stays a small multiple of `eps` times
/// it (as for the looped chains, `macro_indexed_sums.rs`).
fn energy_error<D, H>(
    h: &H,
    z0: dth::nalgebra::OVector<f64, D>,
    steps: usize,
) -> (Vec<Vec<f64>>, f64, f64)
where
    D: dth::nalgebra::Dim,
    H: Hamiltonian<D>,
    dth::nalgebra::DefaultAllocator: dth::Alloc<D>,
{
    let e0 = h.value(&z0);
    let scale = e0.abs().max(z0.component_mul(&h.gradient(&z0)).abs().sum());
    let options = DthOptions::new(0.01).expect("dtau");
    let mut dth = Dth::new(h, z0, options).expect("start");
    let mut drift = 0.0f64;
    let mut midpoints = Vec::with_capacity(steps);
    for _ in 0..steps {
        dth.step().expect("DTH step");
        drift = drift.max((h.value(dth.zbar()) - e0).abs());
        midpoints.push(dth.zbar().as_slice().to_vec());
    }
    (midpoints, drift, scale)
}

/// `f` on a thread with room for the macro types' fixed-size matrices (`D = 512`: 2 MB each).
fn on_a_large_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(512 << 20)
        .spawn(f)
        .expect("a thread")
        .join()
        .expect("the run");
}

#[test]
fn a_cluster_of_64_bodies_from_one_line_keeps_its_energy_text_and_macro() {
    on_a_large_stack(|| {
        const D: usize = 6 * 64;
        let text = RuntimeHamiltonian::new(&gravity_3d(64), &[]).expect("one line");
        assert!(text.looped().is_some(), "the pair sum loops");
        let z0 = cluster_start();
        let steps = 10;
        let (a, drift, scale) = energy_error(&text, DVector::from_vec(z0.clone()), steps);
        eprintln!("64-body cluster, text: energy error {drift:e}, terms {scale}");
        assert!(drift <= 16.0 * f64::EPSILON * scale, "{drift:e} vs {scale}");
        let (b, drift, scale) = energy_error(&Cluster64, SVector::<f64, D>::from_vec(z0), steps);
        assert!(drift <= 16.0 * f64::EPSILON * scale, "{drift:e} vs {scale}");
        assert_eq!(a, b, "the text and the macro take the same steps");
        // And the text at a fixed size, as the macro's type is.
        let fixed = Fixed::<D>::new(text).expect("D");
        assert_eq!(Hamiltonian::<Const<D>>::flags(&fixed), Cluster64.flags());
    });
}

#[test]
fn calogero_moser_of_256_particles_from_one_line_keeps_its_energy_text_and_macro() {
    on_a_large_stack(|| {
        const D: usize = 2 * 256;
        let text = RuntimeHamiltonian::new(&calogero_moser(256), &[("g", 0.5)]).expect("one line");
        assert!(text.looped().is_some(), "the pair sum loops");
        let z0 = calogero_start();
        let steps = 5;
        let (a, drift, scale) = energy_error(&text, DVector::from_vec(z0.clone()), steps);
        eprintln!("Calogero-Moser 256, text: energy error {drift:e}, terms {scale}");
        assert!(drift <= 16.0 * f64::EPSILON * scale, "{drift:e} vs {scale}");
        let h = Calogero256 { g: 0.5 };
        let (b, drift, scale) = energy_error(&h, SVector::<f64, D>::from_vec(z0), steps);
        assert!(drift <= 16.0 * f64::EPSILON * scale, "{drift:e} vs {scale}");
        assert_eq!(a, b, "the text and the macro take the same steps");
    });
}
