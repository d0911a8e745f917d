//! The members of an ensemble scene: the states and parameters its sampler draws ([`draw`])
//! and the energy shell ([`on_shell`]).

use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::Alloc;
use std::collections::BTreeMap;

use dth::Hamiltonian;

use crate::budget::vec_with_capacity;
use crate::error::Error;
use crate::scene::{Axis, Coord, EnergyShell, Members, Sampler, Scene};

/// One member as drawn: its number (its position in the sampler's order, kept when the
/// energy shell skips others), initial `q`, `p` and parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Position in the sampler's order (grid: `x` slowest).
    pub index: usize,
    /// Initial positions.
    pub q: Vec<f64>,
    /// Initial momenta (the shell's momentum is solved later).
    pub p: Vec<f64>,
    /// The system's parameters for this member.
    pub params: BTreeMap<String, f64>,
}

impl Candidate {
    fn set(&mut self, axis: &Axis, v: f64) {
        match axis {
            Axis::Coord(Coord::Q(i)) => self.q[*i] = v,
            Axis::Coord(Coord::P(i)) => self.p[*i] = v,
            // Validation admits no time axis.
            Axis::Coord(Coord::T) => {}
            Axis::Param(name) => {
                self.params.insert(name.clone(), v);
            }
        }
    }
}

/// SplitMix64 (Steele, Lea and Flood 2014): a small generator whose stream is fixed by its
/// seed on every platform, so a seeded ensemble draws the same members everywhere.
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// The generator seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` (53 random bits).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// `count` evenly spaced values from `from` to `to`, both included (`count >= 2`).
fn spaced(from: f64, to: f64, count: usize, i: usize) -> f64 {
    if i + 1 == count {
        to
    } else {
        from + (to - from) * i as f64 / (count - 1) as f64
    }
}

/// Every member `m` draws from `scene`, in order: what the sampler varies set, the rest as the
/// scene's `[initial]` and `[system] params` give it.
///
/// ```
/// use dth_examples::{catalogue::Catalogue, ensemble::sample::draw};
/// let scene = dth_examples::check_scene(
///     "[system]\nname = \"pendulum\"\n[initial]\nq = [0.0]\np = [0.0]\n\
///      [[method]]\nkind = \"rk4\"\ndt = 0.1\n[duration]\nsteps = 10\n\
///      [ensemble]\nkind = \"grid\"\nx = \"q1\"\nx_range = [0.0, 1.0]\nx_count = 3\n",
///     "grid.toml",
///     &Catalogue::builtin(),
/// )?;
/// let members = draw(scene.members.as_ref().unwrap(), &scene)?;
/// let q: Vec<f64> = members.iter().map(|m| m.q[0]).collect();
/// assert_eq!(q, [0.0, 0.5, 1.0]);
/// # Ok::<(), dth_examples::Error>(())
/// ```
///
/// # Errors
/// [`Error::Allocation`] when the list of members cannot be allocated (more members than
/// memory: reachable only with a `--max-memory` above what the machine has, as the memory
/// estimate counts them).
pub fn draw(m: &Members, scene: &Scene) -> Result<Vec<Candidate>, Error> {
    let base = Candidate {
        index: 0,
        q: scene.q.clone(),
        p: scene.p.clone(),
        params: scene.params.clone(),
    };
    let mut out = vec_with_capacity(m.candidates(), || "the members of the ensemble".into())?;
    let mut push = |mut c: Candidate| {
        c.index = out.len();
        out.push(c);
    };
    match &m.sampler {
        Sampler::Grid { x, y } => {
            for i in 0..x.1 {
                let mut c = base.clone();
                c.set(&x.0.axis, spaced(x.0.from, x.0.to, x.1, i));
                match y {
                    None => push(c),
                    Some((y, ny)) => {
                        for j in 0..*ny {
                            let mut c = c.clone();
                            c.set(&y.axis, spaced(y.from, y.to, *ny, j));
                            push(c);
                        }
                    }
                }
            }
        }
        Sampler::Random {
            x,
            y,
            samples,
            seed,
        } => {
            let mut rng = SplitMix64::new(*seed);
            for _ in 0..*samples {
                let mut c = base.clone();
                c.set(&x.axis, x.from + (x.to - x.from) * rng.unit());
                if let Some(y) = y {
                    c.set(&y.axis, y.from + (y.to - y.from) * rng.unit());
                }
                push(c);
            }
        }
        Sampler::List { columns, rows } => {
            for row in rows {
                let mut c = base.clone();
                for (axis, v) in columns.iter().zip(row) {
                    c.set(axis, *v);
                }
                push(c);
            }
        }
    }
    Ok(out)
}

/// Where the energy shell leaves a state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shell {
    /// On the shell: the solved momentum is set.
    On,
    /// No real momentum puts this state on the shell (the member is skipped and counted).
    NoRealSolution,
    /// `H` is not a quadratic polynomial in the solved momentum: the shell is not solved.
    NotQuadratic,
}

/// Puts `z` on the shell `H = E` by setting the momentum `shell.solve` (the other components
/// as they are), taking the larger real root: `p1 >= 0` for `H = p1^2/2 + ...`.
///
/// `H` as a function of that momentum, `f(s) = H - E`, must be a quadratic polynomial (every
/// mechanical `H = |p|^2/(2m) + ...` is): its coefficients are read from `f(-1)`, `f(0)`,
/// `f(1)`, checked at `f(2)`, and the root computed in the cancellation-free form
/// (`Numerical Recipes` 5.6), so the member lands on the shell to roundoff.
pub fn on_shell<D: Dim, S: Hamiltonian<D>>(
    system: &S,
    z: &mut OVector<f64, D>,
    shell: EnergyShell,
) -> Shell
where
    DefaultAllocator: Alloc<D>,
{
    let Some(k) = shell.solve.index(z.len()) else {
        return Shell::NotQuadratic;
    };
    let f = |s: f64| {
        let mut w = z.clone();
        w[k] = s;
        system.value(&w) - shell.energy
    };
    let (fm, c, fp, f2) = (f(-1.0), f(0.0), f(1.0), f(2.0));
    let a = (fp + fm) / 2.0 - c;
    let b = (fp - fm) / 2.0;
    // f(2) = 4a + 2b + c for a quadratic; the four values carry roundoff of eps times their
    // size, so allow a few hundred eps of it.
    let scale = fm.abs() + c.abs() + fp.abs() + f2.abs() + shell.energy.abs();
    if !(f2 - (4.0 * a + 2.0 * b + c))
        .abs()
        .le(&(256.0 * f64::EPSILON * scale))
    {
        return Shell::NotQuadratic;
    }
    let root = if a == 0.0 {
        if b == 0.0 {
            return Shell::NoRealSolution;
        }
        -c / b
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return Shell::NoRealSolution;
        }
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        if q == 0.0 {
            0.0
        } else {
            (q / a).max(c / q)
        }
    };
    if !root.is_finite() {
        return Shell::NoRealSolution;
    }
    z[k] = root;
    Shell::On
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix64_matches_its_reference_stream() {
        // The reference values of SplitMix64 seeded with 1234567 (Vigna's splitmix64.c).
        let mut g = SplitMix64::new(1_234_567);
        assert_eq!(g.next_u64(), 6_457_827_717_110_365_317);
        assert_eq!(g.next_u64(), 3_203_168_211_198_807_973);
        let u = SplitMix64::new(7).unit();
        assert!((0.0..1.0).contains(&u));
    }

    #[test]
    fn spaced_values_hit_both_ends() {
        assert_eq!(spaced(-0.4, 0.6, 11, 0), -0.4);
        assert_eq!(spaced(-0.4, 0.6, 11, 10), 0.6);
        assert!((spaced(-0.4, 0.6, 11, 4) - 0.0).abs() < 1e-16);
    }
}
