//! Shared by the lattice tests (`indexed_sums`, `looped_sums`): seeded points and the
//! roundoff comparison of two evaluations of the same sum.

/// A deterministic point in `[-0.5, 0.5)^d` (SplitMix64).
pub fn point(d: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..d)
        .map(|_| {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect()
}

/// `a` and `b` agree to roundoff: the two evaluations add the same terms in different orders,
/// so each result differs by a few `eps` times the sum of the magnitudes of its terms, which on
/// these points (`|z| < 1/2`, a few dozen terms of size at most 1) is below `64 eps`.
pub fn close(a: f64, b: f64, what: &str) {
    let tol = 64.0 * f64::EPSILON * (1.0 + a.abs().max(b.abs()));
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b}");
}
