//! Effects: observers built only for what a scene requests.
//!
//! [`Effects::new`] constructs one observer per requested effect and nothing else; a scene with
//! no effects never builds an [`Effects`] at all (the runner passes `()`, which the compiler
//! erases). [`Effects::observer_calls`] and [`Effects::stored_values`] count what was done so
//! tests can prove it.

use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::observer::{Observer, StepKind, StepRecord};
use dth::Alloc;
use serde::Serialize;

use crate::normal_modes::ChainModes;
use crate::output_times::{OutputTimes, Wanted};
use crate::scene::{Coord, Direction, EffectSpec, Sampling};
use crate::system::SceneSystem;

/// Mean and max of `|Q_k - Q_ref|` over `k = 1..N` (Table 4.1's "average absolute deviation").
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Deviation {
    /// Mean over the states after the initial one.
    pub mean: f64,
    /// Maximum.
    pub max: f64,
    /// Number of states averaged.
    pub count: usize,
}

impl Deviation {
    /// `(mean, max)`, or `None` when no state after the initial one was seen (a method that
    /// failed at its first step): then there is no deviation to show, and `0` would read as
    /// perfect conservation.
    pub fn observed(&self) -> Option<(f64, f64)> {
        (self.count > 0).then_some((self.mean, self.max))
    }
}

#[derive(Debug, Clone, Default)]
struct Accumulator {
    reference: Option<f64>,
    sum: f64,
    max: f64,
    count: usize,
}

impl Accumulator {
    /// Adds `value`; the first value seen is the reference. Returns the deviation.
    fn add(&mut self, value: f64) -> f64 {
        match self.reference {
            None => {
                self.reference = Some(value);
                0.0
            }
            Some(r) => {
                let d = (value - r).abs();
                self.sum += d;
                self.max = self.max.max(d);
                self.count += 1;
                d
            }
        }
    }

    fn finish(&self) -> Deviation {
        Deviation {
            mean: if self.count > 0 {
                self.sum / self.count as f64
            } else {
                0.0
            },
            max: self.max,
            count: self.count,
        }
    }
}

/// Deviation statistics of one quantity at the states (DTH: midpoints) and, for DTH, at the
/// vertices (reference: the first vertex `z^(0)`, the convention of the thesis's Table 4.1,
/// `docs/thesis.md#table-4-1`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeviationStats {
    /// Quantity name (`energy` or an invariant's name).
    pub name: String,
    /// At the states (DTH: midpoints).
    pub points: Deviation,
    /// At the vertices (DTH only).
    pub vertices: Option<Deviation>,
}

/// A sampled series `(step, t, value)` (e.g. an energy deviation) for CSV and figures.
pub type Series = Vec<(usize, f64, f64)>;

struct Tracked {
    name: String,
    points: Accumulator,
    vertices: Accumulator,
    saw_vertex: bool,
    every: usize,
    series: Series,
    vertex_series: Series,
}

impl Tracked {
    fn new(name: &str, every: usize) -> Self {
        Tracked {
            name: name.to_string(),
            points: Accumulator::default(),
            vertices: Accumulator::default(),
            saw_vertex: false,
            every,
            series: Vec::new(),
            vertex_series: Vec::new(),
        }
    }

    fn add(&mut self, step: usize, t: f64, value: f64, vertex: Option<(f64, f64)>) {
        let d = self.points.add(value);
        let sample = self.every > 0 && step.is_multiple_of(self.every);
        if sample {
            self.series.push((step, t, d));
        }
        if let Some((tv, v)) = vertex {
            self.saw_vertex = true;
            let dv = self.vertices.add(v);
            if sample {
                self.vertex_series.push((step, tv, dv));
            }
        }
    }

    fn stats(&self) -> DeviationStats {
        DeviationStats {
            name: self.name.clone(),
            points: self.points.finish(),
            vertices: self.saw_vertex.then(|| self.vertices.finish()),
        }
    }
}

/// A Poincare section's crossings `(t, x, y)`.
pub type Crossings = Vec<(f64, f64, f64)>;

/// A section: where its points come from, and the points.
struct Section<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    x: Coord,
    y: Coord,
    how: Cut<D>,
    crossings: Crossings,
}

/// How a [`Section`] finds its points.
enum Cut<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// Crossings of `coordinate = value` between consecutive states (`poincare`).
    Level {
        coordinate: Coord,
        value: f64,
        direction: Direction,
        interpolate: bool,
        previous: Option<(f64, OVector<f64, D>)>,
    },
    /// The states at chosen times, landed on (`stroboscopic`).
    Times(Wanted),
}

/// A state as the effects that take states at chosen times record it.
struct Point<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    k: usize,
    t: f64,
    z: OVector<f64, D>,
    lambda: Option<f64>,
    kind: StepKind,
}

impl<D: Dim> Point<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn of(r: &StepRecord<D>) -> Self {
        Point {
            k: r.k,
            t: r.t,
            z: r.z.clone(),
            lambda: r.dth.as_ref().map(|d| d.lambda),
            kind: r.kind,
        }
    }

    /// `self = r`, in place (no allocation per step for a `Dyn` state).
    fn set(&mut self, r: &StepRecord<D>) {
        self.k = r.k;
        self.t = r.t;
        self.z.copy_from(&r.z);
        self.lambda = r.dth.as_ref().map(|d| d.lambda);
        self.kind = r.kind;
    }
}

/// When the `trajectory` effect records a row.
enum RowsAt {
    /// Every `n`-th step.
    Steps(usize),
    /// At chosen times (landed on).
    Times(Wanted),
}

/// The state of a method at the end of its run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FinalState {
    /// Steps taken.
    pub step: usize,
    /// Physical time.
    pub t: f64,
    /// Full phase-space state (extended for time-dependent systems).
    pub z: Vec<f64>,
    /// `lambda` of the last segment (DTH).
    pub lambda: Option<f64>,
}

/// One row of the `trajectory` effect.
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectoryRow {
    /// Step index.
    pub step: usize,
    /// Physical time.
    pub t: f64,
    /// Full phase-space state.
    pub z: Vec<f64>,
    /// `lambda` (DTH).
    pub lambda: Option<f64>,
    /// What produced the step (a DTH step, a fallback step of the robust mode, DTH's last
    /// step shortened to end on time, or a fixed-step method's).
    pub kind: StepKind,
}

/// One row of the `time_law` effect: step, `t` and `lambda` (`None` for fixed-step methods,
/// which have no `lambda`; the CSV leaves it empty, as the trajectory's).
pub type TimeLawRow = (usize, f64, Option<f64>);

/// One row of the `normal_modes` effect: the energies `E_1..E_k` of the first `k` linear
/// normal modes ([`crate::normal_modes`]) at a step.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeEnergies {
    /// Step index.
    pub step: usize,
    /// Physical time.
    pub t: f64,
    /// `E_1..E_k`.
    pub energies: Vec<f64>,
}

/// The most columns (groups of sites) the `space_time` effect records: a raster finer than a
/// figure's pixels shows nothing more, and the record stays small at any size (256 numbers
/// a sample for a chain of 16,384).
pub const SPACE_TIME_COLUMNS: usize = 256;

/// One row of the `space_time` effect: the positions averaged over groups of sites.
#[derive(Debug, Clone, PartialEq)]
pub struct SpaceTimeRow {
    /// Physical time.
    pub t: f64,
    /// The mean of `q_i` over each group of consecutive sites, groups of `n / columns` or
    /// one more sites (the first `n % columns` have one more).
    pub q: Vec<f64>,
}

/// The `space_time` samples of one run.
struct SpaceTimeSamples {
    every: usize,
    rows: Vec<SpaceTimeRow>,
}

/// The index ranges (0-based) of `columns` groups of consecutive sites among `n`: groups of
/// `n / columns` or one more (the first `n % columns` have one more); none when `columns`
/// is 0.
pub fn site_groups(n: usize, columns: usize) -> impl Iterator<Item = std::ops::Range<usize>> {
    let (base, extra) = n
        .checked_div(columns)
        .map_or((0, 0), |base| (base, n % columns));
    (0..columns).scan(0, move |at, c| {
        let len = base + usize::from(c < extra);
        let group = *at..*at + len;
        *at += len;
        Some(group)
    })
}

/// The mean of `q` over `columns` groups of consecutive entries (see [`SpaceTimeRow::q`]).
fn group_means(q: &[f64], columns: usize) -> Vec<f64> {
    site_groups(q.len(), columns)
        .map(|g| q[g.clone()].iter().sum::<f64>() / g.len() as f64)
        .collect()
}

struct ModeSamples {
    every: usize,
    modes: ChainModes,
    rows: Vec<ModeEnergies>,
}

struct PhaseSamples {
    x: Coord,
    y: Coord,
    every: usize,
    /// Absolute end time (`t0 + until`).
    t_end: f64,
    t0: Option<f64>,
    until: f64,
    points: Vec<(f64, f64, f64)>,
}

/// What the effects of one method produced.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EffectOutputs {
    /// `final_state`.
    pub final_state: Option<FinalState>,
    /// `trajectory` rows.
    pub trajectory: Option<Vec<TrajectoryRow>>,
    /// `energy_deviation` (or `comparison_table`) statistics and sampled series.
    pub energy: Option<(DeviationStats, Series, Series)>,
    /// `invariants` (or `comparison_table`): per invariant, statistics and sampled series.
    pub invariants: Option<Vec<(DeviationStats, Series, Series)>>,
    /// `time_law`: `(step, t, lambda)` rows (`lambda` `None` for fixed-step methods).
    pub time_law: Option<Vec<TimeLawRow>>,
    /// `poincare`: one list of crossings per requested section, in scene order.
    pub poincare: Vec<Crossings>,
    /// `phase_plot`: one list of `(t, x, y)` per requested plot, in scene order.
    pub phase: Vec<Vec<(f64, f64, f64)>>,
    /// `normal_modes`: the mode energies every `every` steps.
    pub normal_modes: Option<Vec<ModeEnergies>>,
    /// `space_time`: the positions (grouped) every `every` steps.
    pub space_time: Option<Vec<SpaceTimeRow>>,
}

/// The observers of one method's run, one per requested effect.
pub struct Effects<'s, D: Dim, S: SceneSystem<D>>
where
    DefaultAllocator: Alloc<D>,
{
    system: &'s S,
    final_state: Option<Option<FinalState>>,
    trajectory: Option<(RowsAt, Vec<TrajectoryRow>)>,
    energy: Option<Tracked>,
    invariants: Option<Vec<Tracked>>,
    invariant_buf: Vec<f64>,
    vertex_buf: Vec<f64>,
    time_law: Option<(usize, Vec<TimeLawRow>)>,
    sections: Vec<Section<D>>,
    phase: Vec<PhaseSamples>,
    normal_modes: Option<ModeSamples>,
    space_time: Option<SpaceTimeSamples>,
    calls: usize,
    /// Landings seen ([`Observer::on_landing`]): the index of the next one.
    landings: usize,
    /// The last state seen, kept for effects that want the run's end (`None`: none does, or
    /// none seen yet while `keep_last`).
    last: Option<Point<D>>,
    /// Some effect wants the run's end.
    keep_last: bool,
    /// The chosen times of this run.
    times: &'s OutputTimes,
}

impl<'s, D: Dim, S: SceneSystem<D>> Effects<'s, D, S>
where
    DefaultAllocator: Alloc<D>,
{
    /// Observers for `specs` only, the chosen times of the run resolved in `times`
    /// ([`OutputTimes::new`] of the same `specs`; the run lands on
    /// [`OutputTimes::landings`]). Returns `None` when `specs` is empty: then there is
    /// nothing to observe and the runner uses `()`.
    pub fn new(system: &'s S, specs: &[EffectSpec], times: &'s OutputTimes) -> Option<Self> {
        if specs.is_empty() {
            return None;
        }
        let mut e = Effects {
            system,
            final_state: None,
            trajectory: None,
            energy: None,
            invariants: None,
            invariant_buf: Vec::new(),
            vertex_buf: Vec::new(),
            time_law: None,
            sections: Vec::new(),
            phase: Vec::new(),
            normal_modes: None,
            space_time: None,
            calls: 0,
            landings: 0,
            last: None,
            keep_last: false,
            times,
        };
        let names = system.invariant_names();
        let want_invariants = |every: usize, e: &mut Self| {
            if e.invariants.is_none() {
                e.invariants = Some(names.iter().map(|n| Tracked::new(n, every)).collect());
                e.invariant_buf = vec![0.0; names.len()];
                e.vertex_buf = vec![0.0; names.len()];
            } else if every > 0 {
                for t in e.invariants.iter_mut().flatten() {
                    t.every = every;
                }
            }
        };
        for (i, spec) in specs.iter().enumerate() {
            // Times asked for, resolved; `Wanted::default()` (none) only for a spec missing
            // from `times` (not built from these specs).
            let wanted = || times.wanted(i).unwrap_or_default();
            match *spec {
                EffectSpec::FinalState => e.final_state = Some(None),
                EffectSpec::Trajectory { ref sampling } => {
                    let at = match sampling {
                        Sampling::Steps(every) => RowsAt::Steps(*every),
                        Sampling::EveryTime(_) | Sampling::Times(_) => RowsAt::Times(wanted()),
                    };
                    e.trajectory = Some((at, Vec::new()));
                }
                EffectSpec::Stroboscopic { x, y, .. } => e.sections.push(Section {
                    x,
                    y,
                    how: Cut::Times(wanted()),
                    crossings: Vec::new(),
                }),
                EffectSpec::EnergyDeviation { every } => match &mut e.energy {
                    Some(t) => t.every = every,
                    None => e.energy = Some(Tracked::new("energy", every)),
                },
                EffectSpec::Invariants { every } => want_invariants(every, &mut e),
                // The table needs only the statistics: series stride 0 stores no samples.
                EffectSpec::ComparisonTable => {
                    if e.energy.is_none() {
                        e.energy = Some(Tracked::new("energy", 0));
                    }
                    want_invariants(0, &mut e);
                }
                EffectSpec::TimeLaw { every } => e.time_law = Some((every, Vec::new())),
                EffectSpec::Poincare {
                    coordinate,
                    value,
                    direction,
                    interpolate,
                    x,
                    y,
                } => e.sections.push(Section {
                    x,
                    y,
                    how: Cut::Level {
                        coordinate,
                        value,
                        direction,
                        interpolate,
                        previous: None,
                    },
                    crossings: Vec::new(),
                }),
                EffectSpec::PhasePlot { x, y, every, until } => e.phase.push(PhaseSamples {
                    x,
                    y,
                    every,
                    t_end: f64::INFINITY,
                    t0: None,
                    until: until.unwrap_or(f64::INFINITY),
                    points: Vec::new(),
                }),
                // The chain's n = D/2 (validation admits chains with fixed ends only, which
                // are not time-dependent).
                EffectSpec::NormalModes { modes, every } => {
                    e.normal_modes = Some(ModeSamples {
                        every,
                        modes: ChainModes::new(system.dim().value() / 2, modes),
                        rows: Vec::new(),
                    })
                }
                EffectSpec::SpaceTime { every } => {
                    e.space_time = Some(SpaceTimeSamples {
                        every,
                        rows: Vec::new(),
                    })
                }
            }
        }
        let wants_end = |w: &Wanted| w.end;
        e.keep_last = matches!(&e.trajectory, Some((RowsAt::Times(w), _)) if wants_end(w))
            || e.sections
                .iter()
                .any(|s| matches!(&s.how, Cut::Times(w) if wants_end(w)));
        Some(e)
    }

    /// The state `p`, at a time chosen by the effects for which `pick` says so: a trajectory
    /// row, a stroboscopic section's point.
    fn at_time(&mut self, p: &Point<D>, mut pick: impl FnMut(&mut Wanted) -> bool) {
        if let Some((RowsAt::Times(w), rows)) = &mut self.trajectory {
            if pick(w) {
                rows.push(TrajectoryRow {
                    step: p.k,
                    t: p.t,
                    z: p.z.iter().copied().collect(),
                    lambda: p.lambda,
                    kind: p.kind,
                });
            }
        }
        for s in &mut self.sections {
            if let Cut::Times(w) = &mut s.how {
                if pick(w) {
                    let at = |c: Coord| c.value(p.t, p.z.as_slice());
                    s.crossings.push((p.t, at(s.x), at(s.y)));
                }
            }
        }
    }

    /// How many states were observed.
    pub fn observer_calls(&self) -> usize {
        self.calls
    }

    /// How many numbers are stored (all samples, series, rows and crossings).
    pub fn stored_values(&self) -> usize {
        let d = self.system.dim().value();
        let series = |t: &Tracked| 3 * (t.series.len() + t.vertex_series.len());
        self.final_state
            .as_ref()
            .map_or(0, |f| f.as_ref().map_or(0, |f| f.z.len() + 3))
            + self
                .trajectory
                .as_ref()
                .map_or(0, |(_, rows)| rows.len() * (d + 3))
            + self.last.as_ref().map_or(0, |p| p.z.len() + 4)
            + self.energy.as_ref().map_or(0, series)
            + self
                .invariants
                .as_ref()
                .map_or(0, |v| v.iter().map(series).sum())
            + self.time_law.as_ref().map_or(0, |(_, r)| 3 * r.len())
            + self
                .sections
                .iter()
                .map(|s| 3 * s.crossings.len())
                .sum::<usize>()
            + self.phase.iter().map(|p| 3 * p.points.len()).sum::<usize>()
            + self
                .normal_modes
                .as_ref()
                .map_or(0, |m| m.rows.len() * (m.modes.modes() + 2))
            + self
                .space_time
                .as_ref()
                .map_or(0, |s| s.rows.iter().map(|r| r.q.len() + 1).sum())
    }

    /// Ends observation and hands over the results (the run's last state goes to the effects
    /// that asked for its end time, when it reached it).
    pub fn finish(mut self) -> EffectOutputs {
        if let Some(p) = self
            .last
            .take()
            .filter(|p| p.k > 0 && self.times.is_end(p.t))
        {
            self.at_time(&p, |w| w.end);
        }
        EffectOutputs {
            final_state: self.final_state.flatten(),
            trajectory: self.trajectory.map(|(_, r)| r),
            energy: self
                .energy
                .map(|t| (t.stats(), t.series.clone(), t.vertex_series.clone())),
            invariants: self.invariants.map(|v| {
                v.into_iter()
                    .map(|t| (t.stats(), t.series.clone(), t.vertex_series.clone()))
                    .collect()
            }),
            time_law: self.time_law.map(|(_, r)| r),
            poincare: self.sections.into_iter().map(|s| s.crossings).collect(),
            phase: self.phase.into_iter().map(|p| p.points).collect(),
            normal_modes: self.normal_modes.map(|m| m.rows),
            space_time: self.space_time.map(|s| s.rows),
        }
    }
}

impl<D: Dim, S: SceneSystem<D>> Observer<D> for Effects<'_, D, S>
where
    DefaultAllocator: Alloc<D>,
{
    fn on_landing(&mut self, r: &StepRecord<D>) {
        self.calls += 1;
        let index = self.landings;
        self.landings += 1;
        self.at_time(&Point::of(r), |w| w.takes(index));
    }

    fn on_step(&mut self, r: &StepRecord<D>) {
        self.calls += 1;
        if r.k == 0 {
            self.at_time(&Point::of(r), |w| w.start);
        }
        if self.keep_last {
            match &mut self.last {
                Some(p) => p.set(r),
                None => self.last = Some(Point::of(r)),
            }
        }
        let (step, t, z) = (r.k, r.t, &r.z);
        let lambda = r.dth.as_ref().map(|d| d.lambda);
        // The vertex of a shortened last step belongs to a segment of its own dtau, not to the
        // polygon of equal steps whose vertex invariants the statistics are about.
        let vertex = r
            .dth
            .as_ref()
            .filter(|_| r.kind != StepKind::Shortened)
            .map(|d| (d.vertex_time, &d.vertex));
        let at = |c: Coord, t: f64, z: &OVector<f64, D>| c.value(t, z.as_slice());
        if let Some(f) = &mut self.final_state {
            *f = Some(FinalState {
                step,
                t,
                z: z.iter().copied().collect(),
                lambda,
            });
        }
        if let Some((RowsAt::Steps(every), rows)) = &mut self.trajectory {
            if step.is_multiple_of(*every) {
                rows.push(TrajectoryRow {
                    step,
                    t,
                    z: z.iter().copied().collect(),
                    lambda,
                    kind: r.kind,
                });
            }
        }
        if let Some(tracked) = &mut self.energy {
            let at_vertex = vertex.map(|(tv, zv)| (tv, self.system.value(zv)));
            tracked.add(step, t, self.system.value(z), at_vertex);
        }
        if let Some(inv) = &mut self.invariants {
            self.system.invariants(z, &mut self.invariant_buf);
            if let Some((_, zv)) = vertex {
                self.system.invariants(zv, &mut self.vertex_buf);
            }
            for (i, tracked) in inv.iter_mut().enumerate() {
                let at_vertex = vertex.map(|(tv, _)| (tv, self.vertex_buf[i]));
                tracked.add(step, t, self.invariant_buf[i], at_vertex);
            }
        }
        if let Some((every, rows)) = &mut self.time_law {
            if step.is_multiple_of(*every) {
                rows.push((step, t, lambda));
            }
        }
        for s in &mut self.sections {
            let Cut::Level {
                coordinate,
                value,
                direction,
                interpolate,
                previous,
            } = &mut s.how
            else {
                continue;
            };
            let c1 = at(*coordinate, t, z) - *value;
            if let Some((t0, z0)) = previous.as_ref() {
                let c0 = at(*coordinate, *t0, z0) - *value;
                let up = c0 < 0.0 && c1 >= 0.0;
                let down = c0 > 0.0 && c1 <= 0.0;
                let hit = match direction {
                    Direction::Up => up,
                    Direction::Down => down,
                    Direction::Both => up || down,
                };
                if hit && !*interpolate {
                    // The thesis's sections (Section 4.2): the state just after the crossing,
                    // projected onto the section (its other coordinates kept).
                    s.crossings.push((t, at(s.x, t, z), at(s.y, t, z)));
                } else if hit {
                    // Linear interpolation between the two consecutive observed states (for
                    // DTH these are midpoints, not the vertices of its piecewise-linear path).
                    let a = c0 / (c0 - c1);
                    let zc = z0 + (z - z0) * a;
                    let tc = t0 + (t - t0) * a;
                    s.crossings.push((tc, at(s.x, tc, &zc), at(s.y, tc, &zc)));
                }
            }
            match previous {
                // The stored state is overwritten: no allocation per step for `Dyn`.
                Some((tp, zp)) => {
                    *tp = t;
                    zp.copy_from(z);
                }
                None => *previous = Some((t, z.clone())),
            }
        }
        if let Some(m) = &mut self.normal_modes {
            if step.is_multiple_of(m.every) {
                let (q, p) = z.as_slice().split_at(z.len() / 2);
                let mut energies = vec![0.0; m.modes.modes()];
                m.modes.energies(q, p, &mut energies);
                m.rows.push(ModeEnergies { step, t, energies });
            }
        }
        if let Some(s) = &mut self.space_time {
            if step.is_multiple_of(s.every) {
                let q = &z.as_slice()[..z.len() / 2];
                let columns = q.len().clamp(1, SPACE_TIME_COLUMNS);
                if !q.is_empty() {
                    s.rows.push(SpaceTimeRow {
                        t,
                        q: group_means(q, columns),
                    });
                }
            }
        }
        for p in &mut self.phase {
            if p.t0.is_none() {
                p.t0 = Some(t);
                p.t_end = t + p.until;
            }
            if step.is_multiple_of(p.every) && t <= p.t_end {
                p.points.push((t, at(p.x, t, z), at(p.y, t, z)));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::systems::HarmonicOscillator;

    /// Feeds the exact oscillator solution q = cos t, p = -sin t at t = k h to a Poincare
    /// section q1 = 0 (upward: t = 3 pi / 2, where p = 1).
    fn section(interpolate: bool, h: f64) -> Crossings {
        let sys = HarmonicOscillator { m: 1.0, k: 1.0 };
        let spec = [EffectSpec::Poincare {
            coordinate: Coord::Q(0),
            value: 0.0,
            direction: Direction::Up,
            interpolate,
            x: Coord::T,
            y: Coord::P(0),
        }];
        let times = OutputTimes::none();
        let mut e = Effects::new(&sys, &spec, &times).unwrap();
        for k in 0..=(6.0 / h) as usize {
            let t = k as f64 * h;
            let z = dth::nalgebra::SVector::<f64, 2>::new(t.cos(), -t.sin());
            e.on_step(&StepRecord {
                k,
                t,
                z,
                kind: StepKind::Fixed,
                iterations: 0,
                factorizations: 0,
                dth: None,
            });
        }
        e.finish().poincare.remove(0)
    }

    #[test]
    fn interpolated_crossing_is_second_order_accurate() {
        let h = 0.01;
        let c = section(true, h);
        assert_eq!(c.len(), 1);
        let t_exact = 1.5 * std::f64::consts::PI;
        // Linear interpolation of cos near its zero: error O(h^2), here below h^2.
        assert!((c[0].0 - t_exact).abs() < h * h, "{:?}", c);
        assert!((c[0].2 - 1.0).abs() < h * h, "{:?}", c);
    }

    #[test]
    fn projected_crossing_is_the_first_state_past_the_section() {
        let h = 0.01;
        let c = section(false, h);
        assert_eq!(c.len(), 1);
        let t_exact = 1.5 * std::f64::consts::PI;
        let k = (t_exact / h).ceil();
        assert_eq!(c[0].0, k * h);
        assert_eq!(c[0].1, k * h);
    }
}
