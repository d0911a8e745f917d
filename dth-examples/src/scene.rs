//! Scene files: parsing (TOML, serde, unknown keys rejected) and validation against a
//! [`Catalogue`], with every error located at `file:line:column`.
//!
//! A scene declares a system and its parameters, the initial state, the methods with their
//! steps, the duration and the effects wanted:
//!
//! ```toml
//! title = "Kepler, thesis Table 4.1 settings"
//!
//! [system]
//! name = "kepler"
//! params = { mass = 0.5, k = 1.0 }
//!
//! [initial]
//! q = [0.5, 0.0]
//! p = [0.0, 1.2]
//!
//! [[method]]
//! kind = "dth"
//! dtau = 0.06277
//! lambda0 = 1.0
//!
//! [[method]]
//! kind = "trapezoidal"
//! dt = 0.15
//!
//! [duration]
//! steps = 10000            # or: time = 100.0, or: orbits = 400
//!
//! [[effect]]
//! kind = "energy_deviation"
//! ```

use std::collections::BTreeMap;
use std::ops::Range;

use serde::Deserialize;
use toml::Spanned;

use crate::catalogue::Catalogue;
use crate::error::{Error, SceneDiagnostic, SceneErrors};

// ---------------------------------------------------------------------------------------------
// Raw (as written) form: every key is known, every value that gets a semantic check is spanned.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    title: Option<String>,
    description: Option<String>,
    system: Spanned<RawSystem>,
    initial: Spanned<RawInitial>,
    #[serde(rename = "method")]
    methods: Option<Spanned<Vec<Spanned<RawMethod>>>>,
    duration: Spanned<RawDuration>,
    #[serde(rename = "effect", default)]
    effects: Vec<Spanned<RawEffect>>,
    ensemble: Option<Spanned<RawEnsemble>>,
    thesis_figures: Option<Spanned<bool>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEnsemble {
    x: Spanned<String>,
    y: Spanned<String>,
    half_width: Spanned<f64>,
    per_side: Spanned<i64>,
    steps: Spanned<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSystem {
    name: Spanned<String>,
    #[serde(default)]
    params: BTreeMap<Spanned<String>, Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInitial {
    q: Option<Spanned<Vec<f64>>>,
    p: Option<Spanned<Vec<f64>>>,
    t: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMethod {
    kind: Spanned<String>,
    label: Option<Spanned<String>>,
    dt: Option<Spanned<f64>>,
    dtau: Option<Spanned<f64>>,
    lambda0: Option<Spanned<f64>>,
    solver: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDuration {
    steps: Option<Spanned<i64>>,
    time: Option<Spanned<f64>>,
    orbits: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEffect {
    kind: Spanned<String>,
    every: Option<Spanned<i64>>,
    x: Option<Spanned<String>>,
    y: Option<Spanned<String>>,
    coordinate: Option<Spanned<String>>,
    value: Option<Spanned<f64>>,
    direction: Option<Spanned<String>>,
    until: Option<Spanned<f64>>,
    crossing: Option<Spanned<String>>,
}

// ---------------------------------------------------------------------------------------------
// Validated form.

/// A validated scene: every name resolved, every number in range, every length checked.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Title (defaults to the system name).
    pub title: String,
    /// Free-text description.
    pub description: String,
    /// The system's catalogue name.
    pub system: String,
    /// Parameters, with the catalogue's defaults filled in.
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
    /// A square of initial conditions run for a few steps (thesis Figures 4.10-4.13).
    pub ensemble: Option<Ensemble>,
    /// Draw the thesis's Figures 4.1-4.15 and Table 4.1 ([`crate::thesis`]): a planar system
    /// with a period and an exact solution (Kepler), and the methods exact, trapezoidal,
    /// midpoint, discrete_mechanics and dth.
    pub thesis_figures: bool,
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
        /// Which Newton iteration.
        solver: Solver,
    },
}

/// DTH's Newton solver (issue 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Solver {
    /// One Newton on `(zbar, lambda)` by block elimination (the default).
    Joint,
    /// The thesis's nested algorithm (Section 4.1).
    Nested,
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
            MethodKind::Dth => "Discrete-Time Hamiltonian dynamics; keys dtau, lambda0 (default 1), solver = \"joint\" | \"nested\"",
            MethodKind::Trapezoidal => "trapezoidal rule; key dt",
            MethodKind::Midpoint => "implicit midpoint rule; key dt",
            MethodKind::DiscreteMechanics => "Greenspan's discrete mechanics (central-force H); key dt",
            MethodKind::StormerVerlet => "Stormer-Verlet (separable H); key dt",
            MethodKind::Rk4 => "classical Runge-Kutta 4; key dt",
            MethodKind::GaussLegendre2 => "2-stage Gauss-Legendre (order 4, symplectic); key dt",
            MethodKind::DiscreteGradient => "energy-preserving discrete gradient; key dt",
            MethodKind::Exact => "the system's exact solution sampled every dt (systems that have one: kepler); key dt",
        }
    }

    fn from_name(s: &str) -> Option<Self> {
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
    /// The scene name (`q1`, `p2`, `t`).
    pub fn name(self) -> String {
        match self {
            Coord::Q(i) => format!("q{}", i + 1),
            Coord::P(i) => format!("p{}", i + 1),
            Coord::T => "t".into(),
        }
    }
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
    /// States every `every` steps (CSV).
    Trajectory {
        /// Sampling stride in steps.
        every: usize,
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
}

/// Every effect kind with its keys, for `dth list`.
pub const EFFECTS: [(&str, &str); 8] = [
    ("final_state", "final state of each method (summary.json)"),
    ("trajectory", "states every `every` steps (CSV); key every (default 1)"),
    ("energy_deviation", "|H - H0| per step: mean/max, CSV, figure; key every"),
    ("invariants", "deviation of the system's quadratic invariants; key every"),
    ("poincare", "section crossings; keys coordinate, value (default 0), direction = \"up\" | \"down\" | \"both\", crossing = \"interpolate\" | \"project\" (thesis), x, y"),
    ("time_law", "t and lambda against the step (CSV, figure); key every"),
    ("phase_plot", "figure of y against x for all methods (x = \"t\": a time series); keys x, y, every, until (time span from t0)"),
    ("comparison_table", "table of mean/max energy and invariant deviations of all methods"),
];

// ---------------------------------------------------------------------------------------------
// Parsing and validation.

/// Collects every independent diagnostic of one file (serde_derive's `Ctxt` habit).
struct Ctxt<'a> {
    file: &'a str,
    text: &'a str,
    diagnostics: Vec<SceneDiagnostic>,
}

impl Ctxt<'_> {
    fn error(&mut self, span: Range<usize>, message: impl Into<String>) {
        let (line, column) = line_col(self.text, span.start);
        self.diagnostics.push(SceneDiagnostic {
            file: self.file.to_string(),
            line,
            column,
            message: message.into(),
        });
    }
}

/// 1-based line and column (in characters) of a byte offset.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = text[line_start..offset].chars().count() + 1;
    (line, column)
}

/// Parses and validates a scene. `file` names the source in diagnostics.
///
/// ```
/// use dth_examples::{catalogue::Catalogue, scene::parse};
/// let text = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0]\n\
///             [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[duration]\nsteps = 10\n";
/// let err = parse(text, "bad.toml", &Catalogue::builtin()).unwrap_err();
/// assert!(err.to_string().contains("bad.toml:5:5: initial `p` has 1 value"));
/// ```
pub fn parse(text: &str, file: &str, catalogue: &Catalogue) -> Result<Scene, Error> {
    let raw: RawScene = match toml::from_str(text) {
        Ok(raw) => raw,
        Err(e) => {
            let span = e.span().unwrap_or(0..0);
            let mut cx = Ctxt {
                file,
                text,
                diagnostics: Vec::new(),
            };
            cx.error(span, e.message().trim().to_string());
            return Err(Error::Scene(SceneErrors(cx.diagnostics)));
        }
    };
    let mut cx = Ctxt {
        file,
        text,
        diagnostics: Vec::new(),
    };
    let scene = validate(raw, catalogue, &mut cx);
    match scene {
        Some(scene) if cx.diagnostics.is_empty() => Ok(scene),
        _ => Err(Error::Scene(SceneErrors(cx.diagnostics))),
    }
}

fn validate(raw: RawScene, catalogue: &Catalogue, cx: &mut Ctxt<'_>) -> Option<Scene> {
    let sys_span = raw.system.span();
    let system = raw.system.into_inner();
    let name = system.name.get_ref().clone();
    let info = match catalogue.info(&name) {
        Some(info) => Some(info),
        None => {
            cx.error(
                system.name.span(),
                format!(
                    "unknown system `{name}`: expected one of {}",
                    catalogue.names().join(", ")
                ),
            );
            None
        }
    };
    let _ = sys_span;

    // Parameters: known names only, defaults filled, required ones present, finite values.
    let mut params = BTreeMap::new();
    if let Some(info) = info {
        for (k, v) in &system.params {
            if !info.params.iter().any(|p| p.name == k.get_ref().as_str()) {
                let expected: Vec<_> = info.params.iter().map(|p| p.name).collect();
                cx.error(
                    k.span(),
                    format!(
                        "unknown parameter `{}` of system `{name}`: expected {}",
                        k.get_ref(),
                        if expected.is_empty() {
                            "no parameters".to_string()
                        } else {
                            format!("one of {}", expected.join(", "))
                        }
                    ),
                );
            } else if !v.get_ref().is_finite() {
                cx.error(
                    v.span(),
                    format!("parameter `{}` must be finite", k.get_ref()),
                );
            } else {
                params.insert(k.get_ref().clone(), *v.get_ref());
            }
        }
        for p in info.params {
            if !params.contains_key(p.name) {
                match p.default {
                    Some(d) => {
                        params.insert(p.name.to_string(), d);
                    }
                    None => cx.error(
                        system.name.span(),
                        format!(
                            "system `{name}` needs parameter `{}` ({}): add it to `params`",
                            p.name, p.doc
                        ),
                    ),
                }
            }
        }
    }

    // Initial state: q and p present, length n, finite.
    let init_span = raw.initial.span();
    let initial = raw.initial.into_inner();
    let n = info.map(|i| i.n);
    let vector = |v: Option<Spanned<Vec<f64>>>, what: &str, cx: &mut Ctxt<'_>| match v {
        None => {
            cx.error(
                init_span.clone(),
                format!(
                    "missing initial value `{what}`: expected an array of {} numbers",
                    n.map_or("n".to_string(), |n| n.to_string())
                ),
            );
            None
        }
        Some(v) => {
            if let Some(n) = n {
                if v.get_ref().len() != n {
                    cx.error(
                        v.span(),
                        format!(
                            "initial `{what}` has {} value{}, but system `{name}` has n = {n} degrees of freedom: expected {n}",
                            v.get_ref().len(),
                            if v.get_ref().len() == 1 { "" } else { "s" }
                        ),
                    );
                }
            }
            if let Some(i) = v.get_ref().iter().position(|x| !x.is_finite()) {
                cx.error(v.span(), format!("initial `{what}[{i}]` is not finite"));
            }
            Some(v.into_inner())
        }
    };
    let q = vector(initial.q, "q", cx);
    let p = vector(initial.p, "p", cx);
    let t0 = match initial.t {
        Some(t) if !t.get_ref().is_finite() => {
            cx.error(t.span(), "initial `t` is not finite");
            0.0
        }
        Some(t) => *t.get_ref(),
        None => 0.0,
    };

    // Methods.
    let mut methods = Vec::new();
    match raw.methods {
        None => cx.error(0..0, "no `[[method]]`: expected at least one method"),
        Some(ms) if ms.get_ref().is_empty() => {
            cx.error(ms.span(), "empty method list: expected at least one method")
        }
        Some(ms) => {
            for m in ms.into_inner() {
                let span = m.get_ref().kind.span();
                if let Some(spec) = validate_method(m, cx) {
                    if spec.kind == MethodKind::Exact && info.is_some_and(|i| !i.has_exact) {
                        cx.error(
                            span.clone(),
                            format!("system `{name}` has no exact solution: remove method `exact`"),
                        );
                    }
                    if spec.kind == MethodKind::DiscreteMechanics
                        && info.is_some_and(|i| !i.central_force)
                    {
                        cx.error(
                            span.clone(),
                            format!("method `discrete_mechanics` needs a central-force system H = |p|^2/(2m) + phi(|q|), which `{name}` is not: expected another method"),
                        );
                    }
                    if spec.kind == MethodKind::StormerVerlet && info.is_some_and(|i| !i.separable)
                    {
                        cx.error(
                            span.clone(),
                            format!("method `stormer_verlet` needs a separable H = T(p) + V(q), which `{name}` is not: expected another method"),
                        );
                    }
                    if methods.iter().any(|o: &MethodSpec| o.label == spec.label) {
                        cx.error(
                            span,
                            format!(
                                "two methods are labelled `{}`: give one a distinct `label`",
                                spec.label
                            ),
                        );
                    }
                    methods.push(spec);
                }
            }
        }
    }

    // Duration: exactly one of steps, time, orbits.
    let dspan = raw.duration.span();
    let d = raw.duration.into_inner();
    let given = d.steps.is_some() as u8 + d.time.is_some() as u8 + d.orbits.is_some() as u8;
    let duration = if given != 1 {
        cx.error(
            dspan,
            "duration: expected exactly one of `steps`, `time`, `orbits`",
        );
        None
    } else if let Some(s) = d.steps {
        if *s.get_ref() <= 0 {
            cx.error(
                s.span(),
                format!("`steps` = {}: expected a positive integer", s.get_ref()),
            );
            None
        } else {
            Some(Duration::Steps(*s.get_ref() as usize))
        }
    } else if let Some(t) = d.time {
        positive(&t, "time", cx).map(Duration::Time)
    } else if let Some(o) = d.orbits {
        let v = positive(&o, "orbits", cx);
        if let (Some(_), Some(info)) = (v, info) {
            if !info.has_period {
                cx.error(
                    o.span(),
                    format!("`orbits` needs a known period, which system `{name}` does not provide: use `steps` or `time`"),
                );
            }
        }
        v.map(Duration::Orbits)
    } else {
        None
    };

    // Effects.
    let mut effects = Vec::new();
    for e in raw.effects {
        if let Some(spec) = validate_effect(e, n, info.is_some_and(|i| i.time_dependent), cx) {
            effects.push(spec);
        }
    }

    let ensemble = raw.ensemble.and_then(|e| {
        let e = e.into_inner();
        let x = coord(&e.x, n, "x", cx);
        let y = coord(&e.y, n, "y", cx);
        for c in [(&e.x, x), (&e.y, y)] {
            if c.1 == Some(Coord::T) {
                cx.error(
                    c.0.span(),
                    "the ensemble varies q or p coordinates: expected q1..qn or p1..pn, not t",
                );
            }
        }
        if x.is_some() && x == y {
            cx.error(e.y.span(), "the ensemble's `x` and `y` must differ");
        }
        let half_width = positive(&e.half_width, "half_width", cx);
        let count = |v: &Spanned<i64>, what: &str, min: i64, cx: &mut Ctxt<'_>| {
            if *v.get_ref() >= min {
                Some(*v.get_ref() as usize)
            } else {
                cx.error(
                    v.span(),
                    format!("`{what}` = {}: expected an integer >= {min}", v.get_ref()),
                );
                None
            }
        };
        let per_side = count(&e.per_side, "per_side", 2, cx);
        let steps = count(&e.steps, "steps", 1, cx);
        Some(Ensemble {
            x: x?,
            y: y?,
            half_width: half_width?,
            per_side: per_side?,
            steps: steps?,
        })
    });

    let thesis_figures = match raw.thesis_figures {
        Some(t) if *t.get_ref() => {
            if info.is_some_and(|i| i.n != 2 || i.time_dependent || !i.has_period || !i.has_exact) {
                cx.error(
                    t.span(),
                    format!("`thesis_figures` draws the thesis's Kepler figures: expected a planar system with a period and an exact solution (kepler), not `{name}`"),
                );
            }
            let missing: Vec<&str> = crate::thesis::REQUIRED
                .iter()
                .filter(|k| !methods.iter().any(|m: &MethodSpec| m.kind == **k))
                .map(|k| k.name())
                .collect();
            if !missing.is_empty() {
                cx.error(
                    t.span(),
                    format!(
                        "`thesis_figures` needs the methods exact, trapezoidal, midpoint, discrete_mechanics and dth: add {}",
                        missing.join(", ")
                    ),
                );
            }
            true
        }
        _ => false,
    };

    Some(Scene {
        title: raw.title.unwrap_or_else(|| name.clone()),
        description: raw.description.unwrap_or_default(),
        system: name,
        params,
        q: q?,
        p: p?,
        t0,
        methods,
        duration: duration?,
        effects,
        ensemble,
        thesis_figures,
    })
}

fn positive(v: &Spanned<f64>, what: &str, cx: &mut Ctxt<'_>) -> Option<f64> {
    let x = *v.get_ref();
    if x.is_finite() && x > 0.0 {
        Some(x)
    } else {
        cx.error(
            v.span(),
            format!("`{what}` = {x}: expected a positive, finite number"),
        );
        None
    }
}

fn validate_method(m: Spanned<RawMethod>, cx: &mut Ctxt<'_>) -> Option<MethodSpec> {
    let m = m.into_inner();
    let Some(kind) = MethodKind::from_name(m.kind.get_ref()) else {
        let names: Vec<_> = MethodKind::ALL.iter().map(|k| k.name()).collect();
        cx.error(
            m.kind.span(),
            format!(
                "unknown method `{}`: expected one of {}",
                m.kind.get_ref(),
                names.join(", ")
            ),
        );
        return None;
    };
    let label = m
        .label
        .map(|l| l.into_inner())
        .unwrap_or_else(|| kind.name().to_string());
    if label.is_empty()
        || !label
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        cx.error(
            m.kind.span(),
            format!("label `{label}`: expected letters, digits, `_` or `-` (it names files)"),
        );
    }
    let step = if kind == MethodKind::Dth {
        if let Some(dt) = &m.dt {
            cx.error(dt.span(), "`dt` is not a key of method `dth`: expected `dtau` (the step in tau) and optionally `lambda0`, `solver`");
        }
        let dtau = match &m.dtau {
            None => {
                cx.error(m.kind.span(), "method `dth` needs `dtau` (the step in tau)");
                None
            }
            Some(d) => positive(d, "dtau", cx),
        };
        let lambda0 = match &m.lambda0 {
            None => Some(1.0),
            Some(l) => positive(l, "lambda0", cx),
        };
        let solver = match &m.solver {
            None => Some(Solver::Joint),
            Some(s) => match s.get_ref().as_str() {
                "joint" => Some(Solver::Joint),
                "nested" => Some(Solver::Nested),
                other => {
                    cx.error(
                        s.span(),
                        format!("unknown solver `{other}`: expected \"joint\" or \"nested\""),
                    );
                    None
                }
            },
        };
        StepSpec::Dth {
            dtau: dtau?,
            lambda0: lambda0?,
            solver: solver?,
        }
    } else {
        for (key, v) in [("dtau", &m.dtau), ("lambda0", &m.lambda0)] {
            if let Some(v) = v {
                cx.error(
                    v.span(),
                    format!(
                        "`{key}` is a key of method `dth` only: `{}` takes `dt`",
                        kind.name()
                    ),
                );
            }
        }
        if let Some(s) = &m.solver {
            cx.error(
                s.span(),
                format!(
                    "`solver` is a key of method `dth` only: `{}` takes `dt`",
                    kind.name()
                ),
            );
        }
        let dt = match &m.dt {
            None => {
                cx.error(
                    m.kind.span(),
                    format!("method `{}` needs `dt` (the time step)", kind.name()),
                );
                None
            }
            Some(d) => positive(d, "dt", cx),
        };
        StepSpec::Fixed { dt: dt? }
    };
    Some(MethodSpec { kind, label, step })
}

fn coord(v: &Spanned<String>, n: Option<usize>, what: &str, cx: &mut Ctxt<'_>) -> Option<Coord> {
    let s = v.get_ref().as_str();
    let expected = |n: Option<usize>| {
        n.map_or("q1..qn, p1..pn or t".to_string(), |n| {
            format!("q1..q{n}, p1..p{n} or t")
        })
    };
    if s == "t" {
        return Some(Coord::T);
    }
    let parsed = s
        .strip_prefix('q')
        .map(|r| (true, r))
        .or_else(|| s.strip_prefix('p').map(|r| (false, r)))
        .and_then(|(is_q, r)| r.parse::<usize>().ok().map(|i| (is_q, i)));
    match parsed {
        Some((is_q, i)) if i >= 1 && n.is_none_or(|n| i <= n) => Some(if is_q {
            Coord::Q(i - 1)
        } else {
            Coord::P(i - 1)
        }),
        _ => {
            cx.error(
                v.span(),
                format!(
                    "unknown coordinate `{s}` for `{what}`: expected {}",
                    expected(n)
                ),
            );
            None
        }
    }
}

fn validate_effect(
    e: Spanned<RawEffect>,
    n: Option<usize>,
    _time_dependent: bool,
    cx: &mut Ctxt<'_>,
) -> Option<EffectSpec> {
    let e = e.into_inner();
    let kind = e.kind.get_ref().as_str();
    let allowed: &[&str] = match kind {
        "final_state" | "comparison_table" => &[],
        "trajectory" | "energy_deviation" | "invariants" | "time_law" => &["every"],
        "phase_plot" => &["x", "y", "every", "until"],
        "poincare" => &["coordinate", "value", "direction", "crossing", "x", "y"],
        _ => {
            let names: Vec<_> = EFFECTS.iter().map(|(n, _)| *n).collect();
            cx.error(
                e.kind.span(),
                format!(
                    "unknown effect `{kind}`: expected one of {}",
                    names.join(", ")
                ),
            );
            return None;
        }
    };
    let present: [(&str, Option<Range<usize>>); 8] = [
        ("crossing", e.crossing.as_ref().map(|v| v.span())),
        ("until", e.until.as_ref().map(|v| v.span())),
        ("every", e.every.as_ref().map(|v| v.span())),
        ("x", e.x.as_ref().map(|v| v.span())),
        ("y", e.y.as_ref().map(|v| v.span())),
        ("coordinate", e.coordinate.as_ref().map(|v| v.span())),
        ("value", e.value.as_ref().map(|v| v.span())),
        ("direction", e.direction.as_ref().map(|v| v.span())),
    ];
    for (key, span) in present {
        if let Some(span) = span {
            if !allowed.contains(&key) {
                cx.error(
                    span,
                    format!(
                        "`{key}` is not a key of effect `{kind}`: expected {}",
                        if allowed.is_empty() {
                            "no keys".to_string()
                        } else {
                            allowed.join(", ")
                        }
                    ),
                );
            }
        }
    }
    let every = match &e.every {
        None => Some(1),
        Some(v) if *v.get_ref() >= 1 => Some(*v.get_ref() as usize),
        Some(v) => {
            cx.error(
                v.span(),
                format!("`every` = {}: expected a positive integer", v.get_ref()),
            );
            None
        }
    };
    let need = |v: &Option<Spanned<String>>, what: &str, cx: &mut Ctxt<'_>| match v {
        Some(v) => coord(v, n, what, cx),
        None => {
            cx.error(
                e.kind.span(),
                format!("effect `{kind}` needs `{what}` (a coordinate such as q1 or p1)"),
            );
            None
        }
    };
    Some(match kind {
        "final_state" => EffectSpec::FinalState,
        "comparison_table" => EffectSpec::ComparisonTable,
        "trajectory" => EffectSpec::Trajectory { every: every? },
        "energy_deviation" => EffectSpec::EnergyDeviation { every: every? },
        "invariants" => EffectSpec::Invariants { every: every? },
        "time_law" => EffectSpec::TimeLaw { every: every? },
        "phase_plot" => {
            let x = need(&e.x, "x", cx);
            let y = need(&e.y, "y", cx);
            let until = match &e.until {
                None => Some(None),
                Some(u) => positive(u, "until", cx).map(Some),
            };
            EffectSpec::PhasePlot {
                x: x?,
                y: y?,
                every: every?,
                until: until?,
            }
        }
        "poincare" => {
            let coordinate = need(&e.coordinate, "coordinate", cx);
            let x = need(&e.x, "x", cx);
            let y = need(&e.y, "y", cx);
            let direction = match &e.direction {
                None => Some(Direction::Up),
                Some(d) => match d.get_ref().as_str() {
                    "up" => Some(Direction::Up),
                    "down" => Some(Direction::Down),
                    "both" => Some(Direction::Both),
                    other => {
                        cx.error(
                            d.span(),
                            format!("unknown direction `{other}`: expected \"up\", \"down\" or \"both\""),
                        );
                        None
                    }
                },
            };
            let value = match &e.value {
                None => 0.0,
                Some(v) if v.get_ref().is_finite() => *v.get_ref(),
                Some(v) => {
                    cx.error(v.span(), "`value` must be finite");
                    0.0
                }
            };
            let interpolate = match &e.crossing {
                None => Some(true),
                Some(c) => match c.get_ref().as_str() {
                    "interpolate" => Some(true),
                    "project" => Some(false),
                    other => {
                        cx.error(
                            c.span(),
                            format!("unknown crossing `{other}`: expected \"interpolate\" or \"project\""),
                        );
                        None
                    }
                },
            };
            EffectSpec::Poincare {
                interpolate: interpolate?,
                coordinate: coordinate?,
                value,
                direction: direction?,
                x: x?,
                y: y?,
            }
        }
        _ => unreachable!("kinds are matched above"),
    })
}
