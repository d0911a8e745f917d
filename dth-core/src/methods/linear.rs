//! Dense LU with partial pivoting on stack matrices, generic over `const D` without the
//! `typenum` bounds nalgebra's own `lu()` needs in generic code.

use nalgebra::SMatrix;

/// Solves `A X = B`; `None` when a pivot is at or below `D eps max|A_ij|` (numerically
/// singular: the solution would carry no correct digits) or not finite.
pub(crate) fn solve<const D: usize, const C: usize>(
    mut a: SMatrix<f64, D, D>,
    mut b: SMatrix<f64, D, C>,
) -> Option<SMatrix<f64, D, C>> {
    let tiny = D as f64 * f64::EPSILON * a.amax();
    for k in 0..D {
        let (offset, pivot) =
            a.view_range(k.., k)
                .iter()
                .enumerate()
                .fold((0, 0.0f64), |best, (i, &v)| {
                    if v.abs() > best.1.abs() {
                        (i, v)
                    } else {
                        best
                    }
                });
        if !pivot.is_finite() || pivot.abs() <= tiny || pivot == 0.0 {
            return None;
        }
        let p = k + offset;
        if p != k {
            a.swap_rows(k, p);
            b.swap_rows(k, p);
        }
        for i in k + 1..D {
            let l = a[(i, k)] / pivot;
            if l != 0.0 {
                for j in k + 1..D {
                    a[(i, j)] -= l * a[(k, j)];
                }
                for j in 0..C {
                    b[(i, j)] -= l * b[(k, j)];
                }
            }
        }
    }
    for k in (0..D).rev() {
        for j in 0..C {
            let mut s = b[(k, j)];
            for i in k + 1..D {
                s -= a[(k, i)] * b[(i, j)];
            }
            b[(k, j)] = s / a[(k, k)];
        }
    }
    Some(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    #[test]
    fn solves_a_system_that_needs_pivoting() {
        let a = Matrix3::new(0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0);
        let x = Vector3::new(1.0, -2.0, 0.5);
        let got = solve(a, a * x).unwrap();
        // Backward-stable LU: error a few eps times cond(A) (~10 here).
        assert!((got - x).amax() <= 64.0 * f64::EPSILON, "{got}");
    }

    #[test]
    fn singular_is_none() {
        let a = Matrix3::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 1.0, 1.0);
        assert!(solve(a, Vector3::new(1.0, 1.0, 1.0)).is_none());
        assert!(solve(Matrix3::zeros(), Vector3::new(1.0, 1.0, 1.0)).is_none());
    }
}
