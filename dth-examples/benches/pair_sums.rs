//! N-body systems from one line, their pair sums compiled once and looped
//! (`dth_symbolic::looped::nested`): what compiling and stepping cost against the number of
//! bodies. A plain timing table (no criterion: one DTH step of 1024 gravitating bodies takes
//! seconds), one run, every row measured in it.
//!
//! Per system (3-D gravity, `G = m = 1`; Calogero-Moser, `g = 1/2`) and `N = 64..1024`:
//! - `compile`: `RuntimeHamiltonian::new` on the one-line text (parse, derive the summands,
//!   lay out the pattern, plan and JIT the loops), the median of 3;
//! - `ops`: the summand programs' operations, what the loops' bodies hold;
//! - `hessian`: one evaluation of the Hessian's nonzeros (`N (N - 1) / 2` pair terms), the
//!   median of 3;
//! - `step`: the mean time of one DTH step (`dtau = 0.01`) over 3 steps after a first one (one
//!   step from `D = 3072` on, where a step takes seconds), the Newton iterations on the dense
//!   path (the pair sum's Hessian is a dense block);
//! - `engine`: the part of `compile` in the engine (`dth_symbolic::looped::compile`), the
//!   median of 3;
//! - `engine, written out`: the engine on the same text built term by term
//!   (`dth_symbolic::compile`, no JIT), once, up to 128 bodies (or its error: the written-out
//!   expression has a size limit).
//!
//! `cargo bench -p dth-examples --bench pair_sums` (release), numbers in docs/performance.md.

mod timing;

use std::time::Duration;

use timing::{median, timed};

use dth::dth::{Dth, DthOptions};
use dth::nalgebra::DVector;
use dth_runtime::RuntimeHamiltonian;
use dth_symbolic::sources::{calogero_moser, gravity_3d};

/// A seeded number in `[-1, 1)`.
fn noise(s: &mut u64) -> f64 {
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    2.0 * ((*s >> 11) as f64 / (1u64 << 53) as f64) - 1.0
}

/// Bodies of dimension `dim` on a grid of spacing 1 (a cube's side `ceil(n^(1/dim))`), moved by
/// up to 0.1, velocities up to 0.1.
fn start(n: usize, dim: usize) -> DVector<f64> {
    let side = (1..).find(|s: &usize| s.pow(dim as u32) >= n).unwrap_or(n);
    let mut s = 0x5eed_u64 + n as u64;
    let mut z = DVector::zeros(2 * dim * n);
    for b in 0..n {
        let mut cell = b;
        for k in 0..dim {
            z[dim * b + k] = (cell % side) as f64 + 0.1 * noise(&mut s);
            z[dim * n + dim * b + k] = 0.1 * noise(&mut s);
            cell /= side;
        }
    }
    z
}

fn ms(d: Duration) -> String {
    format!("{:.3}", d.as_secs_f64() * 1e3)
}

/// One row: the system of `n` bodies in `dim` dimensions from `src`.
fn row(name: &str, src: &str, params: &[(&str, f64)], n: usize, dim: usize, written: bool) {
    let compiles: Vec<Duration> = (0..3)
        .map(|_| timed(|| RuntimeHamiltonian::new(src, params).expect("one line")).1)
        .collect();
    let h = RuntimeHamiltonian::new(src, params).expect("one line");
    let looped = h.looped().expect("the pair sum loops");
    let ops = looped.ops();
    let z0 = start(n, dim);
    let nnz = h.hessian_pattern().map_or(0, <[_]>::len);
    let mut values = vec![0.0; nnz];
    let hessian = median(
        (0..3)
            .map(|_| {
                timed(|| {
                    h.hessian_nonzeros_slice(z0.as_slice(), &mut values)
                        .expect("finite")
                })
                .1
            })
            .collect(),
    );
    let options = DthOptions::new(0.01).expect("dtau");
    let mut dth = Dth::new(&h, z0, options).expect("start");
    // Past a few hundred bodies in 3-D a step takes seconds (the dense LU, cubic in `D`):
    // one step there, after a first one elsewhere.
    let steps = if dim * n >= 1536 {
        1
    } else {
        dth.step().expect("first step");
        3
    };
    let (_, elapsed) = timed(|| {
        for _ in 0..steps {
            dth.step().expect("DTH step");
        }
    });
    let step = elapsed / steps as u32;
    let names: Vec<&str> = params.iter().map(|p| p.0).collect();
    let engine = median(
        (0..3)
            .map(|_| timed(|| dth_symbolic::looped::compile(src, &names).expect("loops")).1)
            .collect(),
    );
    let written = if written {
        match timed(|| dth_symbolic::compile(src, &names)) {
            (Ok(w), t) => {
                assert_eq!(w.dim(), 2 * dim * n);
                ms(t)
            }
            (Err(e), t) => format!("refused after {} ms: {e}", ms(t)),
        }
    } else {
        "-".to_string()
    };
    println!(
        "| {name} | {n} | {} | {} | {} | {ops} | {} | {} | {written} |",
        2 * dim * n,
        ms(median(compiles)),
        ms(engine),
        ms(hessian),
        ms(step),
    );
}

fn main() {
    println!(
        "| system | N | D | compile (ms) | of it the engine (ms) | ops | Hessian (ms) \
         | DTH step (ms) | engine, written out (ms) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for n in [64, 128, 256, 512, 1024] {
        let g = [("g", 0.5)];
        row("Calogero-Moser", &calogero_moser(n), &g, n, 1, n <= 128);
    }
    for n in [64, 128, 256, 512, 1024] {
        row("3-D gravity", &gravity_3d(n), &[], n, 3, n <= 128);
    }
}
