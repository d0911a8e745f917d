//! The memory a run's effects will store, estimated before anything runs ([`estimate`]), so a
//! scene that would exhaust the machine is refused with the estimate ([`check`]) instead of
//! growing until it is killed.
//!
//! The estimate counts the numbers the requested effects keep (the same accounting as
//! [`Effects::stored_values`](crate::effects::Effects::stored_values)), per method, from the
//! number of steps the duration implies: exact for `steps` and for fixed-step methods run for a
//! time. DTH's time step `lambda dtau` follows the state along the orbit (and a regularized
//! run's physical step is `|u|^2` times its fictitious one: ~40x `dtau lambda0` on average on
//! the e = 0.99 scene, which starts at pericentre), so for DTH run for a time the count is an
//! estimate: from the average step over the short DTH run `dth check` probes `Psi` on
//! (`crate::probe::time_per_step`: an orbit where the system knows its period, else up to 2,000
//! steps), or from the initial step `lambda0 dtau` where that probe is not run
//! ([`Measure`]). Poincare crossings are bounded by
//! one per two steps (one per step for `direction = "both"`). The thesis figures keep every
//! state of their long runs. An ensemble scene multiplies the effects by its members and adds
//! its table (a row per member and method, as numbers and as the text of its two files).

use crate::driver::Stop;
use crate::error::Error;
use crate::probe;
use crate::scene::{Direction, EffectSpec, MethodKind, Sampling, Scene, StepSpec};
use crate::system::SceneSystem;
use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::Alloc;

/// Bytes per stored number (`f64`).
const BYTES: u64 = 8;

/// Bytes per number of an ensemble scene's table: kept as an `f64` and as text (up to 24
/// characters in the `{:e}` form) in both `ensemble.csv` and `ensemble.json`, which are built
/// in memory before they are written.
const TABLE_BYTES: u64 = BYTES + 2 * 24;

/// What a run would store, by method.
#[derive(Debug, Clone, PartialEq)]
pub struct MemoryEstimate {
    /// Per method: its label, the steps it would take, and the bytes its effects would keep.
    pub methods: Vec<(String, u64, u64)>,
}

impl MemoryEstimate {
    /// The total, in bytes.
    pub fn bytes(&self) -> u64 {
        self.methods
            .iter()
            .map(|m| m.2)
            .fold(0, u64::saturating_add)
    }
}

/// When [`check`] measures DTH's average step (`crate::probe::time_per_step`) instead of
/// assuming its initial one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measure {
    /// Always (`dth check`, which reports the estimate: a probe of milliseconds for most
    /// scenes, up to 2,000 steps of the scene's system).
    Always,
    /// Only when the estimate from the initial step is above the limit, so that a run is not
    /// refused on it (a run: the probe would add to every run what it rarely changes).
    AboveLimit,
}

/// The steps a method takes until `stop`, a DTH step covering `per_unit` times its `dtau
/// lambda0` (see the module docs for DTH run for a time).
fn steps(step: StepSpec, t0: f64, stop: Stop, per_unit: f64) -> u64 {
    let dt = match step {
        StepSpec::Fixed { dt } => dt,
        StepSpec::Dth { dtau, lambda0, .. } => dtau * lambda0 * per_unit,
    };
    stop.fixed_steps(t0, dt) as u64
}

/// The memory the effects of `scene` would keep when run on `system` until `stop`, a DTH run
/// for a time counted from its initial step `lambda0 dtau` (see the module docs).
pub fn estimate<D: Dim, S: SceneSystem<D>>(system: &S, scene: &Scene, stop: Stop) -> MemoryEstimate
where
    DefaultAllocator: Alloc<D>,
{
    estimate_with(system, scene, stop, 1.0)
}

/// [`estimate`] with DTH's average step measured on the probe's run from `z0`
/// (`crate::probe::time_per_step`), where the scene is probed.
pub fn estimate_measured<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    (z0, stop): (&OVector<f64, D>, Stop),
) -> MemoryEstimate
where
    DefaultAllocator: Alloc<D>,
{
    let per_unit = probe::time_per_step(system, scene, z0).unwrap_or(1.0);
    estimate_with(system, scene, stop, per_unit)
}

/// [`estimate`] with a DTH step of `per_unit` times its `dtau lambda0`.
fn estimate_with<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    stop: Stop,
    per_unit: f64,
) -> MemoryEstimate
where
    DefaultAllocator: Alloc<D>,
{
    let d = system.dim().value() as u64;
    let invariants = system.invariant_names().len() as u64;
    let methods = scene
        .methods
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let n = steps(m.step, scene.t0, stop, per_unit);
            let dth = u64::from(matches!(m.step, StepSpec::Dth { .. })) + 1;
            // Saturating: a scene may ask for up to 2^63 steps, and a wrapped estimate would
            // pass the check.
            let samples = |every: usize| (n / every.max(1) as u64).saturating_add(1);
            // States at times `t0 + offset + j step` up to the end (none without an end time).
            let span = stop.limit.end_time().map_or(0.0, |t_end| t_end - scene.t0);
            let timed = |offset: f64, step: f64| ((span - offset) / step).max(0.0) as u64 + 1;
            let mut values = scene
                .effects
                .iter()
                .map(|e| match *e {
                    EffectSpec::FinalState => d + 3,
                    EffectSpec::Trajectory { ref sampling } => match sampling {
                        Sampling::Steps(every) => samples(*every),
                        Sampling::EveryTime(dt) => timed(0.0, *dt),
                        Sampling::Times(times) => times.len() as u64,
                    }
                    .saturating_mul(d + 3),
                    // At most one a period.
                    EffectSpec::Stroboscopic { period, .. } => timed(0.0, period).saturating_mul(3),
                    EffectSpec::EnergyDeviation { every } => samples(every).saturating_mul(3 * dth),
                    EffectSpec::Invariants { every } => {
                        samples(every).saturating_mul(3 * dth * invariants)
                    }
                    EffectSpec::TimeLaw { every } => samples(every).saturating_mul(3),
                    EffectSpec::PhasePlot { every, .. } => samples(every).saturating_mul(3), // t, x, y
                    EffectSpec::Poincare { direction, .. } => {
                        let crossings = match direction {
                            Direction::Both => n,
                            Direction::Up | Direction::Down => n / 2 + 1,
                        };
                        crossings.saturating_mul(3)
                    }
                    EffectSpec::ComparisonTable => 0,
                    EffectSpec::NormalModes { modes, every } => {
                        samples(every).saturating_mul(modes as u64 + 2)
                    }
                    EffectSpec::SpaceTime { every } => samples(every)
                        .saturating_mul((d / 2).min(crate::effects::SPACE_TIME_COLUMNS as u64) + 1),
                })
                .fold(0u64, u64::saturating_add);
            if let Some(e) = &scene.ensemble {
                // Saturating: `per_side` may be up to 2^63 (its square overflowed).
                let square = (e.per_side as u64).saturating_mul(e.per_side as u64);
                values = values.saturating_add(square.saturating_mul(d + 1));
            }
            let mut table = 0u64;
            if let Some(members) = &scene.members {
                // An ensemble scene keeps every member's section crossings until it writes.
                let candidates = members.candidates() as u64;
                values = values.saturating_mul(candidates);
                // And its table: per member and method a row (parameters, start and end
                // states, steps, times, energy error, fallback steps, failure, MEGNO,
                // Lyapunov); the members themselves (state and parameters) are counted with
                // the first method.
                let params = scene.params.len() as u64;
                let mut row = (2 * d + params + 9) * TABLE_BYTES;
                if i == 0 {
                    row += (d + params) * BYTES;
                }
                table = candidates.saturating_mul(row);
            }
            if scene.thesis_figures && MethodKind::THESIS_FIGURES.contains(&m.kind) {
                // Every state of the long run: time and (q1, q2, p1, p2).
                values = values.saturating_add(n.saturating_add(1).saturating_mul(5));
            }
            (
                m.label.clone(),
                n,
                values.saturating_mul(BYTES).saturating_add(table),
            )
        })
        .collect();
    MemoryEstimate { methods }
}

/// The default limit: half the memory the system reports available (`/proc/meminfo`), or
/// 8 GiB where it does not say.
pub fn default_limit() -> u64 {
    let available = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        s.lines()
            .find_map(|l| l.strip_prefix("MemAvailable:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
            .map(|kib| kib * 1024)
    });
    available.map_or(8 << 30, |bytes| bytes / 2)
}

/// An empty vector with room for `n` items, or [`Error::Allocation`] naming `what` when the
/// allocator refuses (more items than memory: reachable with a limit above what the machine
/// has, as the estimate counts them), where `Vec::with_capacity` would panic or abort.
pub fn vec_with_capacity<T>(n: usize, what: impl FnOnce() -> String) -> Result<Vec<T>, Error> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|e| Error::Allocation {
        what: format!("{} ({n} of {} bytes)", what(), std::mem::size_of::<T>()),
        reason: e.to_string(),
    })?;
    Ok(v)
}

/// `bytes` for people: `"3.7 GB"`, `"512.0 MB"`, `"12 bytes"`.
pub fn human(bytes: u64) -> String {
    const UNITS: [(&str, f64); 3] = [("GB", 1e9), ("MB", 1e6), ("kB", 1e3)];
    for (unit, size) in UNITS {
        if bytes as f64 >= size {
            return format!("{:.1} {unit}", bytes as f64 / size);
        }
    }
    format!("{bytes} bytes")
}

/// "about 3.7 GB", or for a saturated estimate "more than a 64-bit count of bytes" (no
/// limit can allow it).
fn about(bytes: u64) -> String {
    if bytes == u64::MAX {
        "more than a 64-bit count of bytes (over 18 EB)".into()
    } else {
        format!("about {}", human(bytes))
    }
}

/// Refuses a run from `z0` until `stop` whose effects would keep more than `limit` bytes,
/// naming the estimate and the largest consumer; DTH's average step measured as `measure`
/// says.
pub fn check<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    (z0, stop): (&OVector<f64, D>, Stop),
    limit: u64,
    measure: Measure,
) -> Result<MemoryEstimate, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let fits = |e: &MemoryEstimate| e.bytes() <= limit && e.bytes() < u64::MAX;
    let mut e = estimate(system, scene, stop);
    let dth_for_a_time = stop.limit.end_time().is_some()
        && scene
            .methods
            .iter()
            .any(|m| matches!(m.step, StepSpec::Dth { .. }));
    if dth_for_a_time && (measure == Measure::Always || !fits(&e)) {
        e = estimate_measured(system, scene, (z0, stop));
    }
    let total = e.bytes();
    // A saturated estimate is more than any limit can allow (`u64::MAX` itself included).
    if fits(&e) {
        return Ok(e);
    }
    let largest = e
        .methods
        .iter()
        .max_by_key(|m| m.2)
        .map_or(String::new(), |(label, n, bytes)| {
            format!("; the largest: `{label}`, {n} steps, {}", about(*bytes))
        });
    let (what, fewer) = match &scene.members {
        Some(m) => (
            format!("the effects and the table of {} members", m.candidates()),
            "fewer members (`samples`, `x_count`, `y_count`, `members`), ",
        ),
        None => ("the effects".to_string(), ""),
    };
    Err(Error::MemoryLimit {
        estimate: total,
        limit,
        detail: format!(
            "{what} would keep {} for {} method(s){largest}, above the limit of {}: \
             {fewer}sample less often (`every`), shorten the duration, drop effects, or raise \
             the limit (--max-memory)",
            about(total),
            e.methods.len(),
            human(limit)
        ),
    })
}
