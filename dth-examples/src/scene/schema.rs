//! The validated form of a scene: what [`parse`](super::parse) returns, every name resolved,
//! every number in range, every length checked. Plain data; nothing here runs anything.

use std::collections::BTreeMap;

use dth::dth::Solver;

use crate::error::SceneDiagnostic;

/// A validated scene: every name resolved, every number in range, every length checked.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Title (defaults to the system name).
    pub title: String,
    /// Free-text description.
    pub description: String,
    /// The system's catalogue name, or for a Hamiltonian given as text its `title` (default
    /// `H = ` and the expression).
    pub system: String,
    /// The Hamiltonian given as text (`[system] hamiltonian = "..."`), when the scene names
    /// no catalogue system.
    pub hamiltonian: Option<TextHamiltonian>,
    /// The regularization DTH runs under (`[system] regularize`, a Hamiltonian given as text
    /// only): `None` for a plain run.
    pub regularize: Option<Regularization>,
    /// Parameters, with the catalogue's defaults filled in (for a Hamiltonian given as text,
    /// those the scene gives, each used by the expression).
    pub params: BTreeMap<String, f64>,
    /// Initial positions, length n.
    pub q: Vec<f64>,
    /// Initial momenta, length n.
    pub p: Vec<f64>,
    /// Initial time (default 0).
    pub t0: f64,
    /// Methods, in scene order.
    pub methods: Vec<MethodSpec>,
    /// How long to integrate.
    pub duration: Duration,
    /// Requested effects, in scene order (nothing else is computed).
    pub effects: Vec<EffectSpec>,
    /// Conditions every method's run watches (`[[event]]`), in scene order.
    pub events: Vec<EventSpec>,
    /// A square of initial conditions run for a few steps (thesis Figures 4.10-4.13).
    pub ensemble: Option<Ensemble>,
    /// An ensemble scene (`[ensemble]` with `kind = "grid" | "random" | "list"`): every member
    /// runs every method for the scene's duration ([`crate::ensemble`]), in place of the
    /// single run from `q`, `p`.
    pub members: Option<Members>,
    /// Draw the thesis's Figures 4.1-4.15 and Table 4.1 (`report::thesis`): a planar system
    /// with a period and an exact solution (Kepler), and the methods of
    /// [`MethodKind::THESIS_FIGURES`].
    pub thesis_figures: bool,
}

/// A Hamiltonian given as text in a scene (`[system] hamiltonian = "..."`, the grammar of
/// `hamiltonian!`), as the symbolic engine read it when the scene was validated: the
/// expression, and what the engine derived from it that validation checks the scene against.
/// Its parameter values are the scene's [`Scene::params`].
#[derive(Debug, Clone, PartialEq)]
pub struct TextHamiltonian {
    /// The expression, as decoded from the TOML string.
    pub source: String,
    /// Degrees of freedom `n`: the largest index of `q` and `p` in the expression.
    pub n: usize,
    /// The phase-space dimension `D`: `2n`, or `2n + 2` when time-dependent.
    pub dim: usize,
    /// `true` when the expression uses `t`: it runs in the extended phase space
    /// `(q, t, p, p_t)` as the macro's types do.
    pub time_dependent: bool,
    /// `true` for `H = T(p) + V(q)` (method `stormer_verlet` runs).
    pub separable: bool,
    /// `true` when `Psi` simplifies to zero (method `dth` cannot run).
    pub psi_identically_zero: bool,
    /// The engine's warnings about the expression (the ones `hamiltonian!` gives as compiler
    /// warnings: a position without its momentum, a misnumbered index), located in the scene
    /// file at the token they concern. They do not stop the scene; `dth check` prints them.
    pub warnings: Vec<SceneDiagnostic>,
}

/// `[system] regularize = "levi-civita" | "ks"` with an optional `centre`: method `dth` runs
/// on the regularized `K = |u|^2 (H + p_t)` of the Hamiltonian given as text, translated so
/// that `centre` is the origin of the map (`crate::regularized`); the peers run on `H` itself.
/// Everything the scene reports is physical (`t`, `q`, `p` and `H`).
#[derive(Debug, Clone, PartialEq)]
pub struct Regularization {
    /// Which map.
    pub map: RegularizeMap,
    /// The centre `c` of the map, `q = c + q(u)`: the point the close approaches are to (one
    /// value per degree of freedom; zeros when the scene gives none).
    pub centre: Vec<f64>,
    /// The text of the Hamiltonian regularized: the scene's `hamiltonian`, or the catalogue
    /// system's own text (`catalogue::SystemEntry::with_text`).
    pub source: String,
}

/// The regularizing maps a scene (`[system] regularize`) and `dth derive --regularize` name
/// (`dth_symbolic::regularize`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RegularizeMap {
    /// Levi-Civita, planar (`n = 2`): `K` on `(u1, u2, t, P1, P2, p_t)`.
    LeviCivita,
    /// Kustaanheimo-Stiefel, in space (`n = 3`): `K` on `(u1..u4, t, P1..P4, p_t)`.
    #[value(alias = "kustaanheimo-stiefel")]
    Ks,
}

impl RegularizeMap {
    /// Both maps, in the order messages name them.
    pub const ALL: [RegularizeMap; 2] = [RegularizeMap::LeviCivita, RegularizeMap::Ks];

    /// The name in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            RegularizeMap::LeviCivita => "levi-civita",
            RegularizeMap::Ks => "ks",
        }
    }

    /// The map named `s`: its [`RegularizeMap::name`], or `kustaanheimo-stiefel` spelled out.
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "kustaanheimo-stiefel" => Some(RegularizeMap::Ks),
            _ => Self::ALL.into_iter().find(|m| m.name() == s),
        }
    }

    /// The degrees of freedom of the physical system it maps.
    pub fn n(self) -> usize {
        match self {
            RegularizeMap::LeviCivita => 2,
            RegularizeMap::Ks => 3,
        }
    }

    /// The engine's regularization of a text (`dth_symbolic::regularize::levi_civita` or
    /// `::kustaanheimo_stiefel`).
    pub fn symbolic(
        self,
    ) -> fn(&str, &[&str]) -> Result<dth_symbolic::System, dth_symbolic::Errors> {
        match self {
            RegularizeMap::LeviCivita => dth_symbolic::regularize::levi_civita,
            RegularizeMap::Ks => dth_symbolic::regularize::kustaanheimo_stiefel,
        }
    }
}

/// A square of initial conditions around the scene's initial state, in the plane of two of
/// its coordinates (`per_side x per_side` points spaced evenly over
/// `[-half_width, half_width]^2`), each run for `steps` steps by every method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ensemble {
    /// First varied coordinate.
    pub x: Coord,
    /// Second varied coordinate.
    pub y: Coord,
    /// Half the side of the square.
    pub half_width: f64,
    /// Points per side (at least 2).
    pub per_side: usize,
    /// Steps each member runs.
    pub steps: usize,
}

/// A method and its step.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodSpec {
    /// Which method.
    pub kind: MethodKind,
    /// Label used in files and tables (default: the kind's name; unique within a scene).
    pub label: String,
    /// Step parameters.
    pub step: StepSpec,
}

impl MethodSpec {
    /// The method's classical order: DTH's `order` (2 to 8), 4 for Gauss-Legendre and RK4, 2
    /// for the others; the exact solution counts as 4 (what the indicators computed along it
    /// can resolve with the fourth-order tangent step).
    pub fn order(&self) -> u32 {
        match (self.kind, self.step) {
            (_, StepSpec::Dth { order, .. }) => order,
            (MethodKind::GaussLegendre2 | MethodKind::Rk4 | MethodKind::Exact, _) => 4,
            _ => 2,
        }
    }
}

/// The step parameters of a method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepSpec {
    /// Fixed physical step `dt > 0`.
    Fixed {
        /// The step.
        dt: f64,
    },
    /// DTH: fixed step `dtau > 0` in tau, initial `lambda0 > 0`, and the Newton solver.
    Dth {
        /// Step in tau.
        dtau: f64,
        /// `lambda_0 = dt/dtau` on the first segment.
        lambda0: f64,
        /// Which Newton iteration (`dth::dth::Solver`, named in scenes by [`Solver::name`]).
        solver: Solver,
        /// Robust mode (`dth::dth::DthOptions::with_robust`): where DTH has no positive root
        /// (a breakdown, `Psi` changing sign), carry on with energy-conserving fallback steps
        /// instead of stopping. Default `false`.
        robust: bool,
        /// The order: 2 (plain DTH, the default), 4, 6 or 8 by symmetric composition of DTH
        /// steps (`dth::dth::DthOptions::with_order`); each step of `dtau` is then 5, 9 or 17
        /// DTH sub-steps, energy exact at every midpoint.
        order: u32,
        /// With `[system] regularize`: start from the exact image of the physical start and
        /// solve every step in double-double (`dth::Solve::start_low`), about 20% more per
        /// step, to DTH's truncation error where a run from doubles stays about 1e-16 of the
        /// time elapsed off. Default `false`.
        double_double: bool,
    },
}

/// The methods a scene can name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MethodKind {
    /// Discrete-Time Hamiltonian dynamics.
    Dth,
    /// Trapezoidal rule.
    Trapezoidal,
    /// Implicit midpoint rule.
    Midpoint,
    /// Greenspan's discrete mechanics (central forces).
    DiscreteMechanics,
    /// Stormer-Verlet (separable H).
    StormerVerlet,
    /// Classical Runge-Kutta 4.
    Rk4,
    /// 2-stage Gauss-Legendre.
    GaussLegendre2,
    /// Energy-preserving discrete-gradient method.
    DiscreteGradient,
    /// The system's exact solution sampled every `dt` (systems that have one, e.g. Kepler).
    Exact,
}

impl MethodKind {
    /// Every method, in the order `dth list` shows them.
    pub const ALL: [MethodKind; 9] = [
        MethodKind::Exact,
        MethodKind::Dth,
        MethodKind::Trapezoidal,
        MethodKind::Midpoint,
        MethodKind::DiscreteMechanics,
        MethodKind::StormerVerlet,
        MethodKind::Rk4,
        MethodKind::GaussLegendre2,
        MethodKind::DiscreteGradient,
    ];

    /// The methods the thesis's figures compare (`thesis_figures = true` needs them all), in
    /// the thesis's order.
    pub const THESIS_FIGURES: [MethodKind; 5] = [
        MethodKind::Exact,
        MethodKind::Trapezoidal,
        MethodKind::Midpoint,
        MethodKind::DiscreteMechanics,
        MethodKind::Dth,
    ];

    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        match self {
            MethodKind::Dth => "dth",
            MethodKind::Trapezoidal => "trapezoidal",
            MethodKind::Midpoint => "midpoint",
            MethodKind::DiscreteMechanics => "discrete_mechanics",
            MethodKind::StormerVerlet => "stormer_verlet",
            MethodKind::Rk4 => "rk4",
            MethodKind::GaussLegendre2 => "gauss_legendre2",
            MethodKind::DiscreteGradient => "discrete_gradient",
            MethodKind::Exact => "exact",
        }
    }

    /// One line for `dth list`.
    pub fn doc(self) -> &'static str {
        match self {
            MethodKind::Dth => "Discrete-Time Hamiltonian dynamics; keys dtau, lambda0 (default 1), solver = \"joint\" | \"nested\", robust = true | false (default false: stop at a breakdown), order = 2 | 4 | 6 | 8 (default 2; 4-8 by symmetric composition), double_double = true | false (default false; with [system] regularize, every step solved in double-double)",
            MethodKind::Trapezoidal => "trapezoidal rule; key dt",
            MethodKind::Midpoint => "implicit midpoint rule; key dt",
            MethodKind::DiscreteMechanics => "Greenspan's discrete mechanics (central-force H); key dt",
            MethodKind::StormerVerlet => "Stormer-Verlet (separable H); key dt",
            MethodKind::Rk4 => "classical Runge-Kutta 4; key dt",
            MethodKind::GaussLegendre2 => "2-stage Gauss-Legendre (order 4, symplectic); key dt",
            MethodKind::DiscreteGradient => "energy-preserving discrete gradient; key dt",
            MethodKind::Exact => "the system's exact solution sampled every dt (systems that have one); key dt",
        }
    }

    /// The method named `s` ([`MethodKind::name`]), if any.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == s)
    }
}

/// How long a run lasts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Duration {
    /// A number of steps (each method takes this many).
    Steps(usize),
    /// Physical time: each method runs until `t >= t0 + time`.
    Time(f64),
    /// A number of orbits of the system's period (systems that know it, e.g. bound Kepler).
    Orbits(f64),
}

/// As people read it: "10,000 steps", "t = 300" (a span from the initial time), "400 orbits".
impl std::fmt::Display for Duration {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Duration::Steps(n) => {
                write!(
                    f,
                    "{} step{}",
                    thousands(n as f64),
                    if n == 1 { "" } else { "s" }
                )
            }
            Duration::Time(t) => write!(f, "t = {t}"),
            Duration::Orbits(k) => write!(f, "{k} orbit{}", if k == 1.0 { "" } else { "s" }),
        }
    }
}

/// `x` rounded to an integer with thousands separators (`3500` -> `"3,500"`).
pub(crate) fn thousands(x: f64) -> String {
    let digits = format!("{:.0}", x.abs());
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    if x < 0.0 && digits != "0" {
        out.insert(0, '-');
    }
    out
}

/// A phase-space coordinate named in a scene: `q1..qn`, `p1..pn` (index into `(q, p)`), or `t`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coord {
    /// `q_{i+1}`.
    Q(usize),
    /// `p_{i+1}`.
    P(usize),
    /// Physical time.
    T,
}

impl Coord {
    /// The coordinate named `s` (`q1..qn`, `p1..pn`, `t`; `n` unknown: any index from 1).
    pub fn from_name(s: &str, n: Option<usize>) -> Option<Coord> {
        if s == "t" {
            return Some(Coord::T);
        }
        let (is_q, index) = s
            .strip_prefix('q')
            .map(|r| (true, r))
            .or_else(|| s.strip_prefix('p').map(|r| (false, r)))?;
        let i: usize = index.parse().ok()?;
        if i == 0 || n.is_some_and(|n| i > n) {
            return None;
        }
        Some(if is_q {
            Coord::Q(i - 1)
        } else {
            Coord::P(i - 1)
        })
    }

    /// The scene name (`q1`, `p2`, `t`).
    pub fn name(self) -> String {
        match self {
            Coord::Q(i) => format!("q{}", i + 1),
            Coord::P(i) => format!("p{}", i + 1),
            Coord::T => "t".into(),
        }
    }

    /// Its index in a phase-space state of dimension `d`, `z = (q, p)` or the extended
    /// `(q, t, p, p_t)`: `q_i` is `z[i - 1]`, `p_i` is `z[d/2 + i - 1]`; `None` for `t`, which
    /// is the state's time, not a component.
    pub fn index(self, d: usize) -> Option<usize> {
        match self {
            Coord::Q(i) => Some(i),
            Coord::P(i) => Some(d / 2 + i),
            Coord::T => None,
        }
    }

    /// Its value in the state `z` at time `t` (NaN for a component outside `z`, which
    /// validation rules out for the scene's own coordinates).
    pub fn value(self, t: f64, z: &[f64]) -> f64 {
        match self.index(z.len()) {
            Some(i) => z.get(i).copied().unwrap_or(f64::NAN),
            None => t,
        }
    }
}

/// The names of the components of a phase-space state with `n` degrees of freedom and
/// dimension `d`: `q1..qn, p1..pn`, or `q1..qn, t_ext, p1..pn, p_t` for the extended phase
/// space (`d = 2n + 2`) of a time-dependent system.
pub fn component_names(n: usize, d: usize) -> Vec<String> {
    let extended = d == 2 * n + 2;
    let mut names: Vec<String> = (1..=n).map(|i| format!("q{i}")).collect();
    if extended {
        names.push("t_ext".into());
    }
    names.extend((1..=n).map(|i| format!("p{i}")));
    if extended {
        names.push("p_t".into());
    }
    names
}

/// An event a run watches (`[[event]]`, `super::events`): where its condition becomes true,
/// located to roundoff, the state is recorded, and the run ends there if it is a stop.
#[derive(Debug, Clone, PartialEq)]
pub struct EventSpec {
    /// Its name (default `event1`, `event2`, ... in scene order).
    pub name: String,
    /// The condition as written (`q1^2 + q2^2 < 0.05^2`).
    pub when: String,
    /// The function of the state whose negative values are the condition: `(lhs) - (rhs)`
    /// for `lhs < rhs`, `(rhs) - (lhs)` for `lhs > rhs`.
    pub g: String,
    /// `action = "stop"`: the run ends where it fires.
    pub stop: bool,
}

/// Direction of a Poincare section crossing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Coordinate increasing through the value.
    Up,
    /// Coordinate decreasing through the value.
    Down,
    /// Either.
    Both,
}

/// An effect: something a run computes and writes, only when the scene asks for it.
#[derive(Debug, Clone, PartialEq)]
pub enum EffectSpec {
    /// The final state of each method (JSON summary).
    FinalState,
    /// States every `every` steps, or at chosen physical times (CSV).
    Trajectory {
        /// When a state is recorded.
        sampling: Sampling,
    },
    /// `|H - H_0|` per step: mean and max in the summary, samples in CSV, a figure.
    EnergyDeviation {
        /// Sampling stride for the CSV series and figure.
        every: usize,
    },
    /// Deviation of the system's quadratic invariants (e.g. angular momentum).
    Invariants {
        /// Sampling stride for the CSV series and figure.
        every: usize,
    },
    /// Crossings of `coordinate = value` (linearly interpolated), plotted in `(x, y)`.
    Poincare {
        /// The section's coordinate.
        coordinate: Coord,
        /// The section's value.
        value: f64,
        /// Which crossings count.
        direction: Direction,
        /// `true`: linear interpolation between the two states either side of the section;
        /// `false`: the thesis's way (Section 4.2), the state just after the crossing,
        /// projected onto the section.
        interpolate: bool,
        /// Horizontal axis of the figure.
        x: Coord,
        /// Vertical axis of the figure.
        y: Coord,
    },
    /// A stroboscopic section of a driven system: the state at every `t = phase + j period`
    /// (`t mod period = phase`) from the start to the end, landed on exactly, plotted in
    /// `(x, y)`.
    Stroboscopic {
        /// The period (of the drive).
        period: f64,
        /// The section's time within a period (`t mod period`).
        phase: f64,
        /// Horizontal axis of the figure.
        x: Coord,
        /// Vertical axis of the figure.
        y: Coord,
    },
    /// `t` and `lambda = dt/dtau` against the step (DTH's time law; `dt` for fixed steps).
    TimeLaw {
        /// Sampling stride.
        every: usize,
    },
    /// A phase plot of `y` against `x` for all methods (`x = "t"` gives a time series).
    PhasePlot {
        /// Horizontal axis.
        x: Coord,
        /// Vertical axis.
        y: Coord,
        /// Sampling stride.
        every: usize,
        /// Only states with `t <= t0 + until` (e.g. one orbit); `None`: all.
        until: Option<f64>,
    },
    /// A table of mean/max energy and invariant deviations of all methods.
    ComparisonTable,
    /// The energy in each of the first `modes` linear normal modes of a chain with fixed ends
    /// (`crate::normal_modes`), every `every` steps: CSV and a figure per method.
    NormalModes {
        /// How many modes, `1..=n` (default 5, as in FPUT's figures, at most `n`).
        modes: usize,
        /// Sampling stride.
        every: usize,
    },
    /// The positions `q_1..q_n` against the site index and `t`, every `every` steps: a
    /// filled raster (colour = displacement) per method, for lattices. Sites are averaged in
    /// at most [`crate::effects::SPACE_TIME_COLUMNS`] groups as they are recorded.
    SpaceTime {
        /// Sampling stride.
        every: usize,
    },
}

/// When the `trajectory` effect records a state.
#[derive(Debug, Clone, PartialEq)]
pub enum Sampling {
    /// Every `n`-th step (`k = 0, n, 2n, ...`), whatever its time.
    Steps(usize),
    /// At `t0, t0 + dt, t0 + 2 dt, ...` up to the end, each landed on exactly.
    EveryTime(f64),
    /// At these physical times (ascending, within the run), each landed on exactly.
    Times(Vec<f64>),
}

impl EffectSpec {
    /// `true` for a section (`poincare`, `stroboscopic`): each writes one list of points,
    /// kept in scene order in `EffectOutputs::poincare`.
    pub fn is_section(&self) -> bool {
        matches!(
            self,
            EffectSpec::Poincare { .. } | EffectSpec::Stroboscopic { .. }
        )
    }

    /// `true` for an effect that records states at chosen times (a `trajectory` with
    /// `every_time` or `times`, a `stroboscopic` section): the run must end at a time.
    pub fn lands_on_times(&self) -> bool {
        match self {
            EffectSpec::Trajectory { sampling } => !matches!(sampling, Sampling::Steps(_)),
            EffectSpec::Stroboscopic { .. } => true,
            _ => false,
        }
    }

    /// A section's name in titles (`section q2 = 0`, `stroboscopic section t mod 6.2832 = 0`)
    /// and its axes; `None` for any other effect.
    pub fn section(&self) -> Option<(String, Coord, Coord)> {
        match self {
            EffectSpec::Poincare {
                coordinate,
                value,
                x,
                y,
                ..
            } => Some((format!("section {} = {value}", coordinate.name()), *x, *y)),
            EffectSpec::Stroboscopic {
                period,
                phase,
                x,
                y,
            } => {
                // Four decimals are enough to tell sections apart in a title.
                let short = |v: f64| {
                    let s = format!("{v:.4}");
                    s.trim_end_matches('0').trim_end_matches('.').to_string()
                };
                Some((
                    format!(
                        "stroboscopic section t mod {} = {}",
                        short(*period),
                        short(*phase)
                    ),
                    *x,
                    *y,
                ))
            }
            _ => None,
        }
    }

    /// Which effect this is.
    pub fn kind(&self) -> EffectKind {
        match self {
            EffectSpec::FinalState => EffectKind::FinalState,
            EffectSpec::Trajectory { .. } => EffectKind::Trajectory,
            EffectSpec::EnergyDeviation { .. } => EffectKind::EnergyDeviation,
            EffectSpec::Invariants { .. } => EffectKind::Invariants,
            EffectSpec::Poincare { .. } => EffectKind::Poincare,
            EffectSpec::Stroboscopic { .. } => EffectKind::Stroboscopic,
            EffectSpec::TimeLaw { .. } => EffectKind::TimeLaw,
            EffectSpec::PhasePlot { .. } => EffectKind::PhasePlot,
            EffectSpec::ComparisonTable => EffectKind::ComparisonTable,
            EffectSpec::NormalModes { .. } => EffectKind::NormalModes,
            EffectSpec::SpaceTime { .. } => EffectKind::SpaceTime,
        }
    }
}

/// The effects a scene can name: one name, one line of documentation and one set of keys
/// each, kept here only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EffectKind {
    /// [`EffectSpec::FinalState`].
    FinalState,
    /// [`EffectSpec::Trajectory`].
    Trajectory,
    /// [`EffectSpec::EnergyDeviation`].
    EnergyDeviation,
    /// [`EffectSpec::Invariants`].
    Invariants,
    /// [`EffectSpec::Poincare`].
    Poincare,
    /// [`EffectSpec::Stroboscopic`].
    Stroboscopic,
    /// [`EffectSpec::TimeLaw`].
    TimeLaw,
    /// [`EffectSpec::PhasePlot`].
    PhasePlot,
    /// [`EffectSpec::ComparisonTable`].
    ComparisonTable,
    /// [`EffectSpec::NormalModes`].
    NormalModes,
    /// [`EffectSpec::SpaceTime`].
    SpaceTime,
}

impl EffectKind {
    /// Every effect, in the order `dth list` shows them.
    pub const ALL: [EffectKind; 11] = [
        EffectKind::FinalState,
        EffectKind::Trajectory,
        EffectKind::EnergyDeviation,
        EffectKind::Invariants,
        EffectKind::Poincare,
        EffectKind::Stroboscopic,
        EffectKind::TimeLaw,
        EffectKind::PhasePlot,
        EffectKind::ComparisonTable,
        EffectKind::NormalModes,
        EffectKind::SpaceTime,
    ];

    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::FinalState => "final_state",
            EffectKind::Trajectory => "trajectory",
            EffectKind::EnergyDeviation => "energy_deviation",
            EffectKind::Invariants => "invariants",
            EffectKind::Poincare => "poincare",
            EffectKind::Stroboscopic => "stroboscopic",
            EffectKind::TimeLaw => "time_law",
            EffectKind::PhasePlot => "phase_plot",
            EffectKind::ComparisonTable => "comparison_table",
            EffectKind::NormalModes => "normal_modes",
            EffectKind::SpaceTime => "space_time",
        }
    }

    /// The effect named `s` ([`EffectKind::name`]), if any.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == s)
    }

    /// `true` when a scene may ask for it more than once (with different keys): each
    /// `phase_plot` is a figure and each `poincare` or `stroboscopic` a section of its own; a
    /// run keeps one of every other effect.
    pub fn repeatable(self) -> bool {
        matches!(
            self,
            EffectKind::PhasePlot | EffectKind::Poincare | EffectKind::Stroboscopic
        )
    }

    /// The keys a scene may give it (besides `kind`).
    pub fn keys(self) -> &'static [&'static str] {
        match self {
            EffectKind::FinalState | EffectKind::ComparisonTable => &[],
            EffectKind::Trajectory => &["every", "every_time", "times"],
            EffectKind::EnergyDeviation
            | EffectKind::Invariants
            | EffectKind::TimeLaw
            | EffectKind::SpaceTime => &["every"],
            EffectKind::PhasePlot => &["x", "y", "every", "until"],
            EffectKind::Poincare => &["coordinate", "value", "direction", "crossing", "x", "y"],
            EffectKind::Stroboscopic => &["period", "phase", "x", "y"],
            EffectKind::NormalModes => &["modes", "every"],
        }
    }

    /// One line for `dth list`.
    pub fn doc(self) -> &'static str {
        match self {
            EffectKind::FinalState => "final state of each method (summary.json)",
            EffectKind::Trajectory => "states every `every` steps (default 1), or at physical times: every_time = dt (t0, t0 + dt, ... up to the end) or times = [..], landed on exactly by every method (CSV); keys every | every_time | times",
            EffectKind::Stroboscopic => "the state at every t = phase + j period, t mod period = phase (a driven system's stroboscopic section), landed on exactly, figure of y against x; keys period, phase (default 0), x, y",
            EffectKind::EnergyDeviation => "|H - H0| per step: mean/max, CSV, figure; key every",
            EffectKind::Invariants => "deviation of the system's quadratic invariants; key every",
            EffectKind::Poincare => "section crossings; keys coordinate, value (default 0), direction = \"up\" | \"down\" | \"both\", crossing = \"interpolate\" | \"project\" (thesis), x, y",
            EffectKind::TimeLaw => "t and lambda against the step (CSV, figure); key every",
            EffectKind::PhasePlot => "figure of y against x for all methods (x = \"t\": a time series); keys x, y, every, until (time span from t0)",
            EffectKind::ComparisonTable => "table of mean/max energy and invariant deviations of all methods",
            EffectKind::NormalModes => "energy in each of the first `modes` linear normal modes of a chain with fixed ends against t (CSV, figure per method); keys modes (default 5), every",
            EffectKind::SpaceTime => "positions q_i against site i and t, a filled raster with a colour bar per method (lattices); key every",
        }
    }
}

// Ensemble scenes (`[ensemble]` with a `kind`; validated in `super::members`).

/// What an ensemble member varies: a phase-space coordinate or a system parameter.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Axis {
    /// A coordinate `q_i` or `p_i` (never `t`).
    Coord(Coord),
    /// A parameter of the system, by name.
    Param(String),
}

impl Axis {
    /// The name a scene gives it (`q2`, `k`).
    pub fn name(&self) -> String {
        match self {
            Axis::Coord(c) => c.name(),
            Axis::Param(p) => p.clone(),
        }
    }
}

/// An axis and the interval `[from, to]` its values are taken from.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisRange {
    /// What varies.
    pub axis: Axis,
    /// Lower end.
    pub from: f64,
    /// Upper end.
    pub to: f64,
}

/// How the members' varied values are chosen.
#[derive(Debug, Clone, PartialEq)]
pub enum Sampler {
    /// `x_count` (times `y_count`) evenly spaced values, ends included, `x` varying slowest.
    Grid {
        /// First axis and its number of points (at least 2).
        x: (AxisRange, usize),
        /// Optional second axis and its number of points.
        y: Option<(AxisRange, usize)>,
    },
    /// `samples` points drawn uniformly from the box, reproducibly from `seed`.
    Random {
        /// First axis.
        x: AxisRange,
        /// Optional second axis.
        y: Option<AxisRange>,
        /// Number of members.
        samples: usize,
        /// The generator's seed (SplitMix64): the same seed draws the same members.
        seed: u64,
    },
    /// Explicit members: a CSV header naming the columns, one row each.
    List {
        /// The columns.
        columns: Vec<Axis>,
        /// The rows (each as long as `columns`).
        rows: Vec<Vec<f64>>,
    },
}

/// Put every member on the energy shell `H = energy` by solving the momentum `solve` from
/// the rest of its state; members with no real solution are skipped and counted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyShell {
    /// The energy `E`.
    pub energy: f64,
    /// The momentum solved for (`Coord::P`).
    pub solve: Coord,
}

/// Chaos indicators an ensemble can compute per member.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChaosIndicator {
    /// The mean exponential growth factor of nearby orbits (Cincotta and Simo 2000), with
    /// Benettin's maximal Lyapunov exponent estimate beside it (`crate::ensemble::chaos`).
    Megno,
}

/// An ensemble scene: many initial states (and parameters), each run with every method.
#[derive(Debug, Clone, PartialEq)]
pub struct Members {
    /// How members are chosen.
    pub sampler: Sampler,
    /// Put on an energy shell, if asked.
    pub shell: Option<EnergyShell>,
    /// A chaos indicator per member, if asked.
    pub chaos: Option<ChaosIndicator>,
}

impl Members {
    /// The number of members drawn before the energy shell skips any.
    pub fn candidates(&self) -> usize {
        match &self.sampler {
            // Saturating: two counts of up to 2^63 each; the memory estimate refuses the product.
            Sampler::Grid { x, y } => x.1.saturating_mul(y.as_ref().map_or(1, |y| y.1)),
            Sampler::Random { samples, .. } => *samples,
            Sampler::List { rows, .. } => rows.len(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thousands_groups_digits() {
        assert_eq!(thousands(3500.0), "3,500");
        assert_eq!(thousands(400.0), "400");
        assert_eq!(thousands(1_234_567.0), "1,234,567");
        assert_eq!(thousands(-10_000.0), "-10,000");
    }

    #[test]
    fn durations_read_as_people_write_them() {
        assert_eq!(Duration::Steps(10_000).to_string(), "10,000 steps");
        assert_eq!(Duration::Steps(1).to_string(), "1 step");
        assert_eq!(Duration::Steps(999).to_string(), "999 steps");
        assert_eq!(Duration::Steps(1_234_567).to_string(), "1,234,567 steps");
        assert_eq!(Duration::Time(300.0).to_string(), "t = 300");
        assert_eq!(Duration::Time(2.5).to_string(), "t = 2.5");
        assert_eq!(Duration::Orbits(400.0).to_string(), "400 orbits");
        assert_eq!(Duration::Orbits(1.0).to_string(), "1 orbit");
    }
}
