//! A catalogue system written as text and compiled at run time (`dth_runtime`, the JIT)
//! returns the bits of the catalogue's `hamiltonian!` type, method by method: the macro emits
//! the engine's programs as Rust and the JIT compiles the same programs, with the same
//! operations in the same order (and the same Rust functions for transcendentals). This also
//! checks that the texts in `dth-runtime/tests/catalogue` are the catalogue's formulas.

use dth::nalgebra::Const;
use dth::nalgebra::SVector;
use dth::Hamiltonian;
use dth_examples::systems;
use dth_runtime::{Backend, RuntimeHamiltonian};

#[path = "../../dth-runtime/tests/catalogue/mod.rs"]
mod catalogue;

use catalogue::{Rng, CATALOGUE};

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Every method of `typed` and of the runtime Hamiltonian built from catalogue entry `name`
/// agree bit for bit at seeded points (two-point methods with a far, a near and an equal
/// second point).
fn same<const D: usize>(name: &str, typed: &impl Hamiltonian<Const<D>>) {
    let e = CATALOGUE.iter().find(|e| e.name == name).unwrap();
    let h = RuntimeHamiltonian::new(e.src, e.params).unwrap();
    assert_eq!(h.backend(), Backend::Jit, "{:?}", h.fallback_reason());
    assert_eq!(h.dimension(), D, "{name}");
    fn flags<const D: usize, H: Hamiltonian<Const<D>>>(h: &H) -> (bool, bool, bool) {
        let f = h.flags();
        (f.separable, f.time_dependent, f.psi_identically_zero)
    }
    assert_eq!(
        (h.separable(), h.time_dependent(), h.psi_identically_zero()),
        flags(typed),
        "{name}: flags"
    );
    let mut rng = Rng(0xca7a_1000 + D as u64);
    let (mut v, mut m) = (vec![0.0; D], vec![0.0; D * D]);
    let mut d = h.derivatives_buffer();
    for _ in 0..10 {
        let z0 = SVector::<f64, D>::from_vec(rng.point(D));
        let dir = SVector::<f64, D>::from_vec(rng.point(D));
        let z = z0.as_slice();
        assert_eq!(
            h.value_slice(z).unwrap().to_bits(),
            typed.value(&z0).to_bits(),
            "{name}"
        );
        h.gradient_slice(z, &mut v).unwrap();
        assert_eq!(bits(&v), bits(typed.gradient(&z0).as_slice()), "{name}");
        // Row-major here, column-major in nalgebra: the same symmetric matrix.
        h.hessian_slice(z, &mut m).unwrap();
        assert_eq!(bits(&m), bits(typed.hessian(&z0).as_slice()), "{name}");
        assert_eq!(
            h.psi_slice(z).unwrap().to_bits(),
            typed.psi(&z0).to_bits(),
            "{name}"
        );
        h.derivatives_slice(z, &mut d).unwrap();
        let t = typed.derivatives(&z0);
        assert_eq!(
            (d.value().to_bits(), d.psi().to_bits()),
            (t.value.to_bits(), t.psi.to_bits()),
            "{name}"
        );
        assert_eq!(bits(d.gradient()), bits(t.gradient.as_slice()), "{name}");
        assert_eq!(bits(d.hessian()), bits(t.hessian.as_slice()), "{name}");
        for step in [0.3, 1e-7, 0.0] {
            let z1 = z0 + dir * step;
            let (a, b) = (z0.as_slice(), z1.as_slice());
            h.discrete_gradient_slice(a, b, &mut v).unwrap();
            let gbar = typed.discrete_gradient(&z0, &z1);
            assert_eq!(bits(&v), bits(gbar.as_slice()), "{name}");
            assert_eq!(
                h.energy_difference_slice(a, b).unwrap().to_bits(),
                typed.energy_difference(&z0, &z1).to_bits(),
                "{name}"
            );
            h.discrete_gradient_defect_slice(a, b, &mut v).unwrap();
            let defect = typed.discrete_gradient_defect(&z0, &z1, &gbar);
            assert_eq!(bits(&v), bits(defect.as_slice()), "{name}");
        }
    }
}

#[test]
fn every_catalogue_system_returns_the_macro_types_bits() {
    let p = |system: &str, k: &str| {
        let e = CATALOGUE.iter().find(|e| e.name == system).unwrap();
        e.params.iter().find(|p| p.0 == k).unwrap().1
    };
    same(
        "kepler",
        &systems::Kepler {
            m: p("kepler", "m"),
            k: p("kepler", "k"),
        },
    );
    let osc = |k| p("harmonic_oscillator", k);
    same(
        "harmonic_oscillator",
        &systems::HarmonicOscillator {
            m: osc("m"),
            k: osc("k"),
        },
    );
    let pen = |k| p("pendulum", k);
    same(
        "pendulum",
        &systems::Pendulum {
            m: pen("m"),
            l: pen("l"),
            g: pen("g"),
        },
    );
    same("henon_heiles", &systems::HenonHeiles);
    let dp = |k| p("double_pendulum", k);
    same(
        "double_pendulum",
        &systems::DoublePendulum {
            m1: dp("m1"),
            m2: dp("m2"),
            l1: dp("l1"),
            l2: dp("l2"),
            g: dp("g"),
        },
    );
    same("toda_chain_4", &systems::TodaChain4);
    same("toda_chain_10", &systems::TodaChain10);
    let fo = |k| p("forced_oscillator", k);
    same(
        "forced_oscillator",
        &systems::ForcedOscillator {
            omega0: fo("omega0"),
            f: fo("f"),
            omega: fo("omega"),
        },
    );
    same(
        "free_particle",
        &systems::FreeParticle {
            m: p("free_particle", "m"),
        },
    );
}
