//! The physical times a scene's effects ask a run to land on (a `trajectory` with
//! `every_time` or `times`: `t0, t0 + dt, ...` or the listed times; `stroboscopic` sections:
//! `t = phase + j period`, the drive's clock), resolved against the run's start `t0` and
//! end `T`: the ascending list the driver lands on beside the run (`dth::solve`'s `save_at`
//! landings, `dth::observer::Observer::on_landing`), and for each effect which of those states
//! are its own, and whether it wants the start and the end (the run's own first and last
//! states).
//!
//! Every method lands on a time exactly (a fixed-step method by a step of what is left, DTH by
//! a step whose `dtau` is scaled onto it, each from the last state before the time), beside the
//! run, so rows of two methods line up in time, each row is the method's own state (a DTH row
//! an exact midpoint, energy at roundoff, not an interpolation), and the run's own steps do not
//! depend on the times asked for.

use crate::error::Error;
use crate::scene::{EffectSpec, Sampling};

/// What one effect asks for: the start, the end, and landings by their index.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Wanted {
    /// The run's start `t0` is one of its times.
    pub start: bool,
    /// The run's end `T` is one of its times.
    pub end: bool,
    /// Indices into [`OutputTimes::landings`], ascending.
    landings: Vec<usize>,
    /// How many of `landings` were seen.
    seen: usize,
}

impl Wanted {
    /// `true` when landing number `index` (the runs report them in order) is one of this
    /// effect's.
    pub fn takes(&mut self, index: usize) -> bool {
        let mine = self.landings.get(self.seen) == Some(&index);
        self.seen += usize::from(mine);
        mine
    }

    /// How many states it asks for in all.
    pub fn count(&self) -> usize {
        self.landings.len() + usize::from(self.start) + usize::from(self.end)
    }
}

/// A scene's chosen times, resolved for one run: see the [module docs](self).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OutputTimes {
    /// Strictly between `t0` and `T`, ascending.
    landings: Vec<f64>,
    /// Per effect of the scene, in scene order (`None`: it asks for no times).
    wanted: Vec<Option<Wanted>>,
    /// `T`.
    t_end: f64,
}

/// The times effect `spec` asks for from `t0` to `t_end`, `None` for an effect that samples by
/// steps or crossings.
fn requested(spec: &EffectSpec, t0: f64, t_end: f64) -> Option<Vec<f64>> {
    // Times `origin + j step` from the start to the end (either included when the grid meets
    // it within the rounding of its sum).
    let tol = tolerance(t0, t_end);
    let grid = |origin: f64, step: f64| {
        let mut first = ((t0 - origin) / step).ceil().max(0.0) as u64;
        if first > 0 && origin + (first - 1) as f64 * step >= t0 - tol {
            first -= 1;
        }
        (first..)
            .map(move |j| origin + j as f64 * step)
            .take_while(move |&t| t <= t_end + tol)
            .collect()
    };
    match spec {
        EffectSpec::Trajectory {
            sampling: Sampling::EveryTime(dt),
        } => Some(grid(t0, *dt)),
        EffectSpec::Trajectory {
            sampling: Sampling::Times(times),
        } => Some(times.clone()),
        // `t mod period = phase`: the drive's clock, whatever the start.
        EffectSpec::Stroboscopic { period, phase, .. } => Some(grid(*phase, *period)),
        _ => None,
    }
}

/// Times within this of `t0` or `T` are those states (the rounding of a time sum).
fn tolerance(t0: f64, t_end: f64) -> f64 {
    4.0 * f64::EPSILON * t0.abs().max(t_end.abs())
}

impl OutputTimes {
    /// The times `effects` ask for in a run from `t0` to `t_end` (`None`: a run of a number of
    /// steps, which validation allows only without chosen times).
    ///
    /// # Errors
    /// [`Error::ChosenTime`] for a time outside the run (before `t0` or after `T`), or
    /// times asked of a run that does not end at a time.
    pub fn new(effects: &[EffectSpec], t0: f64, t_end: Option<f64>) -> Result<Self, Error> {
        let mut asked = Vec::with_capacity(effects.len());
        for spec in effects {
            let times = match t_end {
                Some(t_end) => requested(spec, t0, t_end),
                None if spec.lands_on_times() => {
                    return Err(unavailable(
                        spec,
                        "lands on chosen times, and this run ends after a number of steps: give the duration as `time` or `orbits`".into(),
                    ))
                }
                None => None,
            };
            asked.push(times);
        }
        let t_end = t_end.unwrap_or(t0);
        let tol = tolerance(t0, t_end);
        let mut landings: Vec<f64> = Vec::new();
        for (spec, times) in effects.iter().zip(&asked) {
            for &t in times.iter().flatten() {
                if t < t0 - tol || t > t_end + tol {
                    return Err(unavailable(
                        spec,
                        format!("asks for the state at t = {t}, outside the run from t = {t0} to t = {t_end}"),
                    ));
                }
                if t > t0 + tol && t < t_end - tol {
                    landings.push(t);
                }
            }
        }
        landings.sort_by(f64::total_cmp);
        // One landing for times within the rounding of each other.
        landings.dedup_by(|b, a| *b - *a <= tolerance(*a, *b));
        let wanted = asked
            .into_iter()
            .map(|times| {
                times.map(|times| {
                    let mut w = Wanted::default();
                    for t in times {
                        if (t - t0).abs() <= tol {
                            w.start = true;
                        } else if (t - t_end).abs() <= tol {
                            w.end = true;
                        } else {
                            let i = landings.partition_point(|&l| l < t - tolerance(t, t));
                            if w.landings.last() != Some(&i) {
                                w.landings.push(i);
                            }
                        }
                    }
                    w
                })
            })
            .collect();
        Ok(OutputTimes {
            landings,
            wanted,
            t_end,
        })
    }

    /// No chosen times (ensemble members, a scene without them).
    pub fn none() -> Self {
        OutputTimes::default()
    }

    /// The times strictly inside the run, ascending: what the driver lands on.
    pub fn landings(&self) -> &[f64] {
        &self.landings
    }

    /// What effect number `i` (in scene order) asks for, `None` when it asks for no times.
    pub fn wanted(&self, i: usize) -> Option<Wanted> {
        self.wanted.get(i).cloned().flatten()
    }

    /// `true` when `t` is the run's end `T` (a method that reached it; one that failed
    /// stopped before).
    pub fn is_end(&self, t: f64) -> bool {
        (t - self.t_end).abs() <= tolerance(t, self.t_end)
    }
}

fn unavailable(spec: &EffectSpec, reason: String) -> Error {
    Error::ChosenTime {
        effect: spec.kind().name(),
        reason,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Coord;

    fn trajectory(sampling: Sampling) -> EffectSpec {
        EffectSpec::Trajectory { sampling }
    }

    #[test]
    fn every_time_covers_the_run_and_shares_landings_with_a_section() {
        let effects = [
            trajectory(Sampling::EveryTime(0.5)),
            EffectSpec::EnergyDeviation { every: 1 },
            EffectSpec::Stroboscopic {
                period: 1.0,
                phase: 0.25,
                x: Coord::Q(0),
                y: Coord::P(0),
            },
        ];
        let times = OutputTimes::new(&effects, 1.0, Some(3.0)).unwrap();
        // 1.5, 2, 2.5 (trajectory) and 1.25, 2.25 (section); 1 and 3 are the start and end.
        assert_eq!(times.landings(), [1.25, 1.5, 2.0, 2.25, 2.5]);
        let mut t = times.wanted(0).unwrap();
        assert!(t.start && t.end);
        assert_eq!(t.count(), 5);
        let taken: Vec<usize> = (0..5).filter(|&i| t.takes(i)).collect();
        assert_eq!(taken, [1, 2, 4]);
        assert_eq!(times.wanted(1), None);
        let mut s = times.wanted(2).unwrap();
        assert!(!s.start && !s.end);
        let taken: Vec<usize> = (0..5).filter(|&i| s.takes(i)).collect();
        assert_eq!(taken, [0, 3]);
        assert!(times.is_end(3.0) && !times.is_end(2.5));
    }

    #[test]
    fn a_stroboscopic_section_keeps_the_drives_clock() {
        // t mod 0.5 = 0.25 from t0 = 0.7: 0.75, 1.25, 1.75 (not 0.95, 1.45, ...).
        let section = [EffectSpec::Stroboscopic {
            period: 0.5,
            phase: 0.25,
            x: Coord::Q(0),
            y: Coord::P(0),
        }];
        let times = OutputTimes::new(&section, 0.7, Some(2.0)).unwrap();
        assert_eq!(times.landings(), [0.75, 1.25, 1.75]);
        // A start on the section is its first point.
        let times = OutputTimes::new(&section, 0.25, Some(1.0)).unwrap();
        assert_eq!(times.landings(), [0.75]);
        assert!(times.wanted(0).unwrap().start);
    }

    #[test]
    fn a_grid_that_meets_the_end_by_rounding_ends_on_it() {
        // 0.1 * 30 is 3.0000000000000004: the end, not a time after it.
        let times = OutputTimes::new(&[trajectory(Sampling::EveryTime(0.1))], 0.0, Some(3.0));
        let times = times.unwrap();
        assert_eq!(times.landings().len(), 29);
        assert!(times.wanted(0).unwrap().end);
    }

    #[test]
    fn times_outside_the_run_or_without_an_end_time_are_refused() {
        let listed = [trajectory(Sampling::Times(vec![0.5, 12.0]))];
        let e = OutputTimes::new(&listed, 0.0, Some(10.0)).unwrap_err();
        assert!(e.to_string().contains("t = 12"), "{e}");
        let e = OutputTimes::new(&listed, 1.0, Some(10.0)).unwrap_err();
        assert!(e.to_string().contains("t = 0.5"), "{e}");
        let e = OutputTimes::new(&listed, 0.0, None).unwrap_err();
        assert!(e.to_string().contains("`time` or `orbits`"), "{e}");
        let steps = [trajectory(Sampling::Steps(3))];
        assert_eq!(
            OutputTimes::new(&steps, 0.0, None).unwrap(),
            OutputTimes {
                landings: vec![],
                wanted: vec![None],
                t_end: 0.0
            }
        );
    }
}
