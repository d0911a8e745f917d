//! One Newton iteration's linear algebra (numeric factorization + one solve, the symbolic
//! analysis done once outside the loop) for the matrices `I - c J Hess` of the implicit peers,
//! three Hessian patterns, `D = 64, 256, 1024`:
//! - `banded`: a chain (tridiagonal q-block, identity on p): FPUT, Toda, Frenkel-Kontorova;
//! - `block`: clusters of 8 particles in 1D, all pairs coupled within a cluster (8 x 8 dense
//!   q-blocks), no coupling between clusters;
//! - `arrow`: a chain plus one particle coupled to every other (a heavy centre, or the DTH
//!   border: one row and column full).
//!
//! Candidates: `banded`, `dth_core::structured::BandedLu` (reverse Cuthill-McKee, banded
//! partial pivoting); `faer`, faer 0.23's sparse LU (`factorize_symbolic_lu` once, then
//! `factorize_numeric_lu` and `solve_in_place_with_conj` with preallocated scratch, sequential).
//!
//! Run from this directory: `cargo bench --bench solvers -- --noplot`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use dth_core::structured::BandedLu;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, NumericLu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, Triplet};
use faer::{Conj, MatMut, Par};

/// The upper-triangle Hessian pattern of `n` particles in 1D (`D = 2n`).
fn hessian_pattern(kind: &str, n: usize) -> Vec<(usize, usize)> {
    let mut p = Vec::new();
    for i in 0..n {
        match kind {
            "banded" => {
                p.push((i, i));
                if i + 1 < n {
                    p.push((i, i + 1));
                }
            }
            "block" => {
                let end = (i / 8 + 1) * 8;
                for j in i..end.min(n) {
                    p.push((i, j));
                }
            }
            "arrow" => {
                if i == 0 {
                    for j in 0..n {
                        p.push((0, j));
                    }
                } else {
                    p.push((i, i));
                    if i + 1 < n {
                        p.push((i, i + 1));
                    }
                }
            }
            _ => unreachable!(),
        }
    }
    for i in n..2 * n {
        p.push((i, i));
    }
    p
}

/// The entries of `I - c J Hess` for that pattern, with seeded Hessian values of size about 1
/// and `c = 0.05` (a well-conditioned Newton matrix, as at the peers' steps).
fn newton_matrix(kind: &str, n: usize) -> (usize, Vec<(usize, usize)>, Vec<f64>) {
    let d = 2 * n;
    let mut seed = 0x5EEDu64;
    let mut rng = || {
        seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut x = seed;
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((x ^ (x >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut entries: Vec<(usize, usize)> = (0..d).map(|i| (i, i)).collect();
    let mut values = vec![1.0; d];
    for (i, j) in hessian_pattern(kind, n) {
        let h = 0.5 + rng();
        let mirror = if i == j { None } else { Some((j, i)) };
        for (r, c) in std::iter::once((i, j)).chain(mirror) {
            let (row, sign) = if r >= n { (r - n, 1.0) } else { (r + n, -1.0) };
            entries.push((row, c));
            values.push(-0.05 * sign * h);
        }
    }
    (d, entries, values)
}

/// faer's sparse LU with its symbolic analysis done once and scratch preallocated.
struct Faer {
    symbolic_matrix: SymbolicSparseColMat<usize>,
    /// Where each entry's value goes in the CSC value array.
    position: Vec<usize>,
    csc: Vec<f64>,
    lu: SymbolicLu<usize>,
    numeric: NumericLu<usize, f64>,
    buffer: MemBuffer,
}

impl Faer {
    fn analyse(d: usize, entries: &[(usize, usize)]) -> Faer {
        let triplets: Vec<Triplet<usize, usize, f64>> = entries
            .iter()
            .map(|&(r, c)| Triplet::new(r, c, 1.0))
            .collect();
        let m = faer::sparse::SparseColMat::<usize, f64>::try_new_from_triplets(d, d, &triplets)
            .expect("valid pattern");
        let symbolic_matrix = m.symbolic().to_owned().expect("memory");
        let col_ptr = symbolic_matrix.col_ptr();
        let row_idx = symbolic_matrix.row_idx();
        let position = entries
            .iter()
            .map(|&(r, c)| {
                let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
                col_ptr[c] + rows.binary_search(&r).expect("entry in the pattern")
            })
            .collect();
        let lu = factorize_symbolic_lu(symbolic_matrix.as_ref(), Default::default())
            .expect("symbolic LU");
        let scratch = lu
            .factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default())
            .or(lu.solve_in_place_scratch::<f64>(1, Par::Seq));
        Faer {
            csc: vec![0.0; row_idx.len()],
            symbolic_matrix,
            position,
            lu,
            numeric: NumericLu::new(),
            buffer: MemBuffer::new(scratch),
        }
    }

    fn factor_solve(&mut self, values: &[f64], b: &mut [f64]) {
        self.csc.fill(0.0);
        for (&p, &v) in self.position.iter().zip(values) {
            self.csc[p] += v;
        }
        let a = SparseColMatRef::new(self.symbolic_matrix.as_ref(), &self.csc);
        let stack = MemStack::new(&mut self.buffer);
        let lu = self
            .lu
            .factorize_numeric_lu(&mut self.numeric, a, Par::Seq, stack, Default::default())
            .expect("nonsingular");
        let n = b.len();
        let rhs = MatMut::from_column_major_slice_mut(b, n, 1);
        lu.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut self.buffer));
    }
}

fn solvers(c: &mut Criterion) {
    for kind in ["banded", "block", "arrow"] {
        for n in [32, 128, 512] {
            let (d, entries, values) = newton_matrix(kind, n);
            let rhs: Vec<f64> = (0..d).map(|i| (i as f64).sin()).collect();
            let mut banded = BandedLu::analyse(d, &entries).expect("valid pattern");
            let mut faer = Faer::analyse(d, &entries);
            // The two agree (both backward stable on a well-conditioned matrix).
            let mut x = rhs.clone();
            banded.factor(&values).expect("nonsingular");
            banded.solve(&mut x);
            let mut y = rhs.clone();
            faer.factor_solve(&values, &mut y);
            let diff = x
                .iter()
                .zip(&y)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let (kl, ku) = banded.bandwidths();
            eprintln!("{kind} D = {d}: bandwidths ({kl}, {ku}), |banded - faer| = {diff:.1e}");
            assert!(diff < 1e-12, "{kind} {d}: solvers disagree by {diff}");
            let mut g = c.benchmark_group(format!("factor_solve/{kind}_{d}"));
            let mut b = rhs.clone();
            g.bench_function("banded", |bch| {
                bch.iter(|| {
                    b.copy_from_slice(&rhs);
                    banded.factor(black_box(&values)).expect("nonsingular");
                    banded.solve(&mut b);
                    black_box(b[0])
                })
            });
            g.bench_function("faer", |bch| {
                bch.iter(|| {
                    b.copy_from_slice(&rhs);
                    faer.factor_solve(black_box(&values), &mut b);
                    black_box(b[0])
                })
            });
            g.finish();
        }
    }
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
        .sample_size(20)
}

criterion_group! {
    name = benches;
    config = config();
    targets = solvers
}
criterion_main!(benches);
