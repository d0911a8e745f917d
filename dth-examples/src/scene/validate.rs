//! Validation of a scene against the systems a [`SystemLookup`] knows (a catalogue, or
//! anything else that can describe systems by name), with every error located at
//! `file:line:column` and all independent errors reported at once.

use std::collections::BTreeMap;
use std::ops::Range;

use toml::Spanned;

use super::raw::{RawEffect, RawMethod, RawScene};
use super::suggest::did_you_mean;
use super::{events, expression, initial, members, regularization};
use dth::dth::{Composition, Solver};
use dth::runtime::{Backend, RuntimeHamiltonian};

use super::schema::{
    Coord, Direction, Duration, EffectKind, EffectSpec, Ensemble, MethodKind, MethodSpec, Sampling,
    Scene, StepSpec, TextHamiltonian,
};
use crate::error::{Error, SceneDiagnostic, SceneErrors};

/// A named parameter of a system.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// Name used in the scene's `params` table.
    pub name: &'static str,
    /// Default, or `None` when the scene must give it.
    pub default: Option<f64>,
    /// One line of documentation.
    pub doc: &'static str,
    /// The values it may take. Validation enforces it (on the value a scene gives, or on the
    /// default), so a system's builder receives only values that satisfy it.
    pub rule: ParamRule,
}

/// The values a parameter may take (beyond being finite, which every parameter must be).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum ParamRule {
    /// Any finite number.
    #[default]
    Any,
    /// `> 0` (a mass, a length, a force constant).
    Positive,
    /// `>= 0`.
    NonNegative,
}

impl ParamRule {
    /// `true` when `value` satisfies the rule (`value` is finite).
    pub fn allows(self, value: f64) -> bool {
        match self {
            ParamRule::Any => true,
            ParamRule::Positive => value > 0.0,
            ParamRule::NonNegative => value >= 0.0,
        }
    }

    /// The rule as a suffix for listings (", > 0"; empty for [`ParamRule::Any`]).
    pub fn bound(self) -> &'static str {
        match self {
            ParamRule::Any => "",
            ParamRule::Positive => ", > 0",
            ParamRule::NonNegative => ", >= 0",
        }
    }

    /// What the rule expects, for messages ("a positive number (> 0)").
    pub fn expected(self) -> &'static str {
        match self {
            ParamRule::Any => "a finite number",
            ParamRule::Positive => "a positive number (> 0)",
            ParamRule::NonNegative => "a non-negative number (>= 0)",
        }
    }
}

impl ParamSpec {
    /// A parameter that may take any finite value, with a default (`None`: required).
    pub const fn new(name: &'static str, default: Option<f64>, doc: &'static str) -> Self {
        ParamSpec {
            name,
            default,
            doc,
            rule: ParamRule::Any,
        }
    }

    /// The same parameter, restricted to `rule`.
    pub const fn with_rule(mut self, rule: ParamRule) -> Self {
        self.rule = rule;
        self
    }

    /// The same parameter, restricted to positive values ([`ParamRule::Positive`]).
    pub const fn positive(self) -> Self {
        self.with_rule(ParamRule::Positive)
    }

    /// Checks `value` against the parameter's rule (and finiteness) for `system`; the error
    /// says what was expected ("parameter `m` of system `pendulum` = 0: expected a positive
    /// number (> 0)"). Validation reports it at the value; [`crate::catalogue::Catalogue::run`]
    /// checks a hand-built scene with it too.
    pub fn check(&self, system: &str, value: f64) -> Result<f64, String> {
        if value.is_finite() && self.rule.allows(value) {
            Ok(value)
        } else {
            Err(format!(
                "parameter `{}` ({}) of system `{system}` = {value}: expected {}",
                self.name,
                self.doc,
                self.rule.expected()
            ))
        }
    }
}

/// What validation needs to know about a system.
#[derive(Debug, Clone, Copy)]
pub struct SystemInfo<'a> {
    /// Degrees of freedom `n` (length of `q` and `p`; time is not counted).
    pub n: usize,
    /// Parameters.
    pub params: &'a [ParamSpec],
    /// `true` for `H(t, q, p)` (run in the extended phase space).
    pub time_dependent: bool,
    /// `true` when the system can give an orbit period (durations in `orbits`).
    pub has_period: bool,
    /// `true` when the system has an exact solution (method `exact`).
    pub has_exact: bool,
    /// `true` for `H = T(p) + V(q)` (method `stormer_verlet`).
    pub separable: bool,
    /// `true` for a central force `|p|^2/(2m) + phi(|q|)` (method `discrete_mechanics`).
    pub central_force: bool,
    /// `true` for a chain with fixed ends of unit masses and springs (to second order): the
    /// effect `normal_modes` applies (`SceneSystem::FIXED_END_CHAIN`).
    pub fixed_end_chain: bool,
    /// `true` when method `dth` can run.
    pub dth: bool,
    /// `true` when `Psi` is identically zero (`Flags::psi_identically_zero`): the reason
    /// DTH is not offered, when it is not.
    pub psi_identically_zero: bool,
    /// The system as text, in the grammar of a scene's `hamiltonian` (with its sizes after
    /// `where` for a sizable system): a scene that sets its sizes runs this text at them, and
    /// a scene that regularizes it (`[system] regularize`) runs DTH on this text's `K`.
    pub text: Option<&'a str>,
    /// `true` when a scene may set the system's sizes (`[system] sizes`; it has a `text`).
    pub sizable: bool,
}

impl SystemInfo<'_> {
    /// `true` when method `kind` can run on this system: `exact` needs an exact solution,
    /// `discrete_mechanics` a central force, `stormer_verlet` a separable `H`, `dth` a `Psi`
    /// not identically zero; the others run on every system. Validation rejects the rest.
    pub fn offers(&self, kind: MethodKind) -> bool {
        match kind {
            MethodKind::Exact => self.has_exact,
            MethodKind::DiscreteMechanics => self.central_force,
            MethodKind::StormerVerlet => self.separable,
            MethodKind::Dth => self.dth,
            MethodKind::Trapezoidal
            | MethodKind::Midpoint
            | MethodKind::Rk4
            | MethodKind::GaussLegendre2
            | MethodKind::DiscreteGradient => true,
        }
    }
}

/// The systems a scene may name, as validation sees them (implemented by
/// [`Catalogue`](crate::catalogue::Catalogue)).
pub trait SystemLookup {
    /// What validation needs to know about the system `name`, if it is known.
    fn info(&self, name: &str) -> Option<SystemInfo<'_>>;
    /// Every known name, for "expected one of" messages.
    fn names(&self) -> Vec<&str>;
}

/// Collects every independent diagnostic of one file (serde_derive's `Ctxt` habit).
struct Ctxt<'a> {
    file: &'a str,
    text: &'a str,
    diagnostics: Vec<SceneDiagnostic>,
}

impl Ctxt<'_> {
    fn error(&mut self, span: Range<usize>, message: impl Into<String>) {
        let diagnostic = self.locate(span, message);
        self.diagnostics.push(diagnostic);
    }

    /// `message` at the start of `span`, as `file:line:column`.
    fn locate(&self, span: Range<usize>, message: impl Into<String>) -> SceneDiagnostic {
        let (line, column) = line_col(self.text, span.start);
        SceneDiagnostic {
            file: self.file.to_string(),
            line,
            column,
            message: message.into(),
        }
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
pub fn parse(text: &str, file: &str, systems: &dyn SystemLookup) -> Result<Scene, Error> {
    let headers = header_mistakes(text);
    if !headers.is_empty() {
        let mut cx = Ctxt {
            file,
            text,
            diagnostics: Vec::new(),
        };
        for (span, message) in headers {
            cx.error(span, message);
        }
        return Err(Error::Scene(SceneErrors(cx.diagnostics)));
    }
    // Every structural error (unknown key, wrong type) at once, then the rules on what
    // remains, less what follows from a structural error already reported.
    let structure = super::structure::read(text);
    let mut cx = Ctxt {
        file,
        text,
        diagnostics: Vec::new(),
    };
    for (span, message) in structure.errors {
        cx.error(span, plain_types(&message));
    }
    let Some(raw) = structure.raw else {
        return Err(Error::Scene(SceneErrors(cx.diagnostics)));
    };
    let structural = cx.diagnostics.len();
    let scene = validate(raw, systems, &mut cx);
    if !structure.touched.is_empty() {
        let touched: Vec<(usize, usize)> = structure
            .touched
            .iter()
            .map(|t| line_col(text, t.start))
            .collect();
        let mut i = 0;
        cx.diagnostics.retain(|d| {
            i += 1;
            i <= structural || !touched.contains(&(d.line, d.column))
        });
    }
    match scene {
        Some(scene) if cx.diagnostics.is_empty() => Ok(scene),
        _ => Err(Error::Scene(SceneErrors(cx.diagnostics))),
    }
}

fn validate(raw: RawScene, systems: &dyn SystemLookup, cx: &mut Ctxt<'_>) -> Option<Scene> {
    // The system: a catalogue name, or a Hamiltonian given as text (exactly one of the two).
    // A missing table is one error each, all reported at once (serde stopped at the first),
    // and validation goes on with an empty one.
    let missing_system = raw.system.is_none();
    let (system_span, system) = table(
        raw.system,
        "system",
        "`name` (a catalogue system, see `dth list`) or `hamiltonian` (H as text)",
        cx,
    );
    let mut hamiltonian = None;
    let (name, info, params) = match (&system.name, &system.hamiltonian) {
        (Some(name), None) => {
            if let Some(title) = &system.title {
                cx.error(
                    title.span(),
                    "`title` names a Hamiltonian given as text (`hamiltonian`): a catalogue system is named by `name` (give the scene a `title` at the top instead)",
                );
            }
            let entry = systems.info(name.get_ref());
            let sized = match system.sizes.iter().next() {
                None => None,
                Some((size, _)) => {
                    let text = entry.as_ref().filter(|i| i.sizable).and_then(|i| i.text);
                    if text.is_none() && entry.is_some() {
                        let sizable: Vec<String> = systems
                            .names()
                            .into_iter()
                            .filter(|n| systems.info(n).is_some_and(|i| i.sizable))
                            .map(|n| format!("`{n}`"))
                            .collect();
                        cx.error(
                            size.span(),
                            format!(
                                "`{}` has its own size: `sizes` sets the sizes of {} or of a Hamiltonian given as text (`hamiltonian = \"... where N = ..\"`)",
                                name.get_ref(),
                                sizable.join(", ")
                            ),
                        );
                    }
                    text
                }
            };
            match sized {
                // The catalogue's text at the scene's sizes: a text system, named after the
                // entry (its parameters' defaults filled in, located at the name).
                Some(text) => {
                    let mut given = system.params.clone();
                    for spec in entry.as_ref().map_or(&[][..], |i| i.params) {
                        if let (Some(default), false) =
                            (spec.default, given.keys().any(|k| k.get_ref() == spec.name))
                        {
                            given.insert(
                                Spanned::new(name.span(), spec.name.to_string()),
                                Spanned::new(name.span(), default),
                            );
                        }
                    }
                    let sizes: Vec<String> = system
                        .sizes
                        .iter()
                        .map(|(k, v)| format!("{} = {}", k.get_ref(), v.get_ref()))
                        .collect();
                    let title = format!("{}, {}", name.get_ref(), sizes.join(", "));
                    let source = Spanned::new(name.span(), text.to_string());
                    let (name, info, params, h) =
                        text_system(&source, &given, &system.sizes, title, cx);
                    hamiltonian = h;
                    (name, info, params)
                }
                None => catalogue_system(name, &system.params, systems, cx),
            }
        }
        (None, Some(source)) => {
            // Named by its expression as written, with the sizes the scene set (which the
            // text's own `where N = ..` no longer says).
            let sizes: String = system
                .sizes
                .iter()
                .map(|(k, v)| format!(", {} = {}", k.get_ref(), v.get_ref()))
                .collect();
            let title = match &system.title {
                Some(t) => t.get_ref().clone(),
                None => format!(
                    "H = {}{}",
                    source
                        .get_ref()
                        .split_whitespace()
                        .collect::<Vec<_>>()
                        .join(" "),
                    if sizes.is_empty() {
                        String::new()
                    } else {
                        format!(" (sizes set by the scene: {})", &sizes[2..])
                    }
                ),
            };
            let (name, info, params, h) =
                text_system(source, &system.params, &system.sizes, title, cx);
            hamiltonian = h;
            (name, info, params)
        }
        (Some(name), Some(source)) => {
            cx.error(
                source.span(),
                "`[system]` takes `name` (a catalogue system) or `hamiltonian` (H as text), not both",
            );
            (name.get_ref().clone(), None, BTreeMap::new())
        }
        (None, None) if missing_system => (String::new(), None, BTreeMap::new()),
        (None, None) => {
            cx.error(
                system_span,
                "`[system]` needs `name` (a catalogue system, see `dth list`) or `hamiltonian` (H as text in the grammar of `hamiltonian!`)",
            );
            (String::new(), None, BTreeMap::new())
        }
    };
    let text = hamiltonian.is_some();

    // Initial state: q and p present, length n, finite.
    let missing_initial = raw.initial.is_none();
    let (init_span, mut initial) = table(raw.initial, "initial", "`q` and `p`", cx);
    let n = info.map(|i| i.n);
    // Formulas and files become numbers, checked below as a list would be.
    // The sizes a text declares (after `sizes` set them), or a sizable catalogue system's
    // (`fput_alpha`'s N = 32).
    let sized_source = hamiltonian
        .as_ref()
        .map(|h| h.source.as_str())
        .or(info.as_ref().and_then(|i| i.text));
    let mut names = sized_source
        .map(initial::declared_sizes)
        .unwrap_or_default();
    names.extend(params.iter().map(|(k, v)| (k.clone(), *v)));
    let mut errors = Vec::new();
    let resolved = initial::resolve(cx.text, cx.file, &mut initial, n, names, &mut errors);
    for (span, message) in errors {
        cx.error(span, message);
    }
    let vector = |v: Option<Spanned<Vec<f64>>>, what: &str, cx: &mut Ctxt<'_>| match v {
        None if missing_initial => None,
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
    let q_span = resolved.q.as_ref().map(|v| v.span());
    let q = vector(resolved.q, "q", cx);
    let p = vector(resolved.p, "p", cx);
    let t0 = match initial.t {
        Some(t) if !t.get_ref().is_finite() => {
            cx.error(t.span(), "initial `t` is not finite");
            0.0
        }
        Some(t) => *t.get_ref(),
        None => resolved.t.unwrap_or(0.0),
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
                    if spec.kind == MethodKind::Exact && info.is_some_and(|i| !i.offers(spec.kind))
                    {
                        cx.error(
                            span.clone(),
                            format!("system `{name}` has no exact solution: remove method `exact`"),
                        );
                    }
                    if spec.kind == MethodKind::DiscreteMechanics
                        && info.is_some_and(|i| !i.offers(spec.kind))
                    {
                        cx.error(
                            span.clone(),
                            format!("method `discrete_mechanics` needs a central-force system H = |p|^2/(2m) + phi(|q|), which `{name}` is not: expected another method"),
                        );
                    }
                    if let Some(i) =
                        info.filter(|i| spec.kind == MethodKind::Dth && !i.offers(spec.kind))
                    {
                        cx.error(
                            span.clone(),
                            if i.psi_identically_zero {
                                format!("method `dth` cannot integrate system `{name}`: its Psi = (J gradH)^T HessH (J gradH) is identically zero, so the energy condition does not determine lambda = dt/dtau (thesis Section 3.4): expected a peer method (midpoint, trapezoidal, rk4, gauss_legendre2, discrete_gradient, ...)")
                            } else {
                                format!("method `dth` is not offered for system `{name}` (registered without DTH): expected a peer method")
                            },
                        );
                    }
                    if matches!(
                        spec.step,
                        StepSpec::Dth {
                            double_double: true,
                            ..
                        }
                    ) && system.regularize.is_none()
                    {
                        cx.error(
                            span.clone(),
                            "`double_double` solves a regularized run in double-double: it needs `[system] regularize` (a run of H itself starts from doubles)",
                        );
                    }
                    if spec.kind == MethodKind::StormerVerlet
                        && info.is_some_and(|i| !i.offers(spec.kind))
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

    // Regularization: method `dth` on the regularized K of a Hamiltonian given as text.
    let names: Vec<&str> = params.keys().map(String::as_str).collect();
    let mut errors = Vec::new();
    let source = hamiltonian
        .as_ref()
        .map(|h| h.source.as_str())
        .or(info.as_ref().and_then(|i| i.text));
    let regularize = regularization::check(
        (system.regularize.as_ref(), system.centre.as_ref()),
        source
            .zip(info.as_ref())
            .map(|(source, i)| regularization::Text {
                source,
                n: i.n,
                params: &names,
            }),
        regularization::Context {
            name: &name,
            known: info.is_some(),
            has_dth: methods.iter().any(|m| m.kind == MethodKind::Dth),
            q: q.as_deref().zip(q_span),
        },
        &mut errors,
    );
    for (span, message) in errors {
        cx.error(span, message);
    }

    // Duration: exactly one of steps, time, orbits.
    let missing_duration = raw.duration.is_none();
    let (dspan, d) = table(
        raw.duration,
        "duration",
        "one of `steps`, `time`, `orbits`",
        cx,
    );
    let given = d.steps.is_some() as u8 + d.time.is_some() as u8 + d.orbits.is_some() as u8;
    let duration = if missing_duration {
        None
    } else if given != 1 {
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
    let mut effects: Vec<EffectSpec> = Vec::new();
    let mut effect_spans: Vec<Range<usize>> = Vec::new();
    for e in raw.effects {
        let span = e.get_ref().kind.span();
        if let Some(spec) = validate_effect(e, n, cx) {
            // A run keeps one of each effect but `phase_plot` and `poincare` (one per figure
            // or section): a second `energy_deviation` would silently replace the first, and
            // a second identical figure or section would be computed twice.
            let first = effects.iter().zip(&effect_spans).find(|(other, _)| {
                **other == spec || (other.kind() == spec.kind() && !spec.kind().repeatable())
            });
            if let Some((_, at)) = first {
                let (line, _) = line_col(cx.text, at.start);
                cx.error(
                    span,
                    format!(
                        "effect `{}` is asked twice (first on line {line}){}: remove one",
                        spec.kind().name(),
                        if spec.kind().repeatable() {
                            " with the same keys"
                        } else {
                            ", and a run keeps one of it"
                        }
                    ),
                );
                continue;
            }
            effects.push(spec);
            effect_spans.push(span);
        }
    }

    // States at chosen times are landed on by a run that ends at a time.
    if let Some(Duration::Steps(_)) = duration {
        for (spec, span) in effects.iter().zip(&effect_spans) {
            if spec.lands_on_times() {
                cx.error(
                    span.clone(),
                    format!("effect `{}` records states at chosen times, which a run of a number of steps does not reach exactly: give the duration as `time` or `orbits`", spec.kind().name()),
                );
            }
        }
    }

    // A Hamiltonian given as text declares its energy and nothing else.
    if text {
        for (spec, span) in effects.iter().zip(&effect_spans) {
            if spec.kind() == EffectKind::Invariants {
                cx.error(
                    span.clone(),
                    format!("effect `invariants` measures a system's quadratic invariants (e.g. Kepler's angular momentum), and a Hamiltonian given as text declares none: `{name}` has its energy only (effect `energy_deviation`)"),
                );
            }
        }
    }

    // Normal modes are those of a chain with fixed ends: a catalogue system says whether it is
    // one; a Hamiltonian given as text is checked on its expansion at rest.
    let wants_modes = effects.iter().any(|s| s.kind() == EffectKind::NormalModes);
    let not_a_chain = match (&hamiltonian, info) {
        (Some(h), _) if wants_modes => text_chain_mismatch(h, &params)
            .map(|why| format!("the Hamiltonian given as text is not one: {why}")),
        (None, Some(i)) if !i.fixed_end_chain => Some(format!("system `{name}` is not one")),
        _ => None,
    };
    if let Some(why) = not_a_chain {
        for (spec, span) in effects.iter().zip(&effect_spans) {
            if spec.kind() == EffectKind::NormalModes {
                cx.error(
                    span.clone(),
                    format!(
                        "effect `normal_modes` needs a chain with fixed ends (unit masses and springs to second order, e.g. fput_alpha, fput_beta, toda_fixed_ends): {why}"
                    ),
                );
            }
        }
    }

    // `[ensemble]`: the thesis's square (no `kind`), or an ensemble scene (`members`).
    let param_names: Vec<&str> = if text {
        params.keys().map(String::as_str).collect()
    } else {
        info.map_or(Vec::new(), |i| i.params.iter().map(|p| p.name).collect())
    };
    let (ensemble, members) = match raw.ensemble {
        None => (None, None),
        Some(e) => {
            let at = e.span();
            let e = e.into_inner();
            match e.kind.clone() {
                Some(kind) if kind.get_ref() != "square" => {
                    let mut errors = Vec::new();
                    let m = members::check(cx.text, e, &kind, at, n, &param_names, &mut errors);
                    for (span, message) in errors {
                        cx.error(span, message);
                    }
                    (None, m)
                }
                _ => (square(e, at, n, cx), None),
            }
        }
    };
    if members.is_some() {
        // An ensemble scene collects the section crossings of every member; its table holds
        // each member's final state and energy error.
        for (spec, span) in effects.iter().zip(&effect_spans) {
            if !spec.is_section() {
                cx.error(
                    span.clone(),
                    format!("effect `{}` is not collected over an ensemble: expected `poincare` or `stroboscopic` (the ensemble's table has every member's final state and energy error)", spec.kind().name()),
                );
            }
        }
    }

    // Events: conditions in the Hamiltonian's grammar, over this system's coordinates.
    let event_spans: Vec<Range<usize>> = raw.events.iter().map(Spanned::span).collect();
    let events = {
        let values: Vec<(&str, f64)> = params.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        let time_dependent = info.is_some_and(|i| i.time_dependent);
        let mut errors = Vec::new();
        let events = events::check(cx.text, raw.events, n, time_dependent, &values, &mut errors);
        for (span, message) in errors {
            cx.error(span, message);
        }
        events
    };
    if members.is_some() {
        if let Some(span) = event_spans.first() {
            cx.error(
                span.clone(),
                "events are watched in single runs: an ensemble scene collects sections (`poincare`, `stroboscopic`), not events",
            );
        }
    }

    let thesis_figures = match raw.thesis_figures {
        Some(t) if *t.get_ref() => {
            if members.is_some() {
                cx.error(
                    t.span(),
                    "`thesis_figures` draws one run's figures, not an ensemble scene's: remove it or the ensemble's `kind`",
                );
            }
            if info.is_some_and(|i| i.n != 2 || i.time_dependent || !i.has_period || !i.has_exact) {
                cx.error(
                    t.span(),
                    format!("`thesis_figures` draws the thesis's Kepler figures: expected a planar system with a period and an exact solution (kepler), not `{name}`"),
                );
            }
            let missing: Vec<&str> = MethodKind::THESIS_FIGURES
                .iter()
                .filter(|k| !methods.iter().any(|m: &MethodSpec| m.kind == **k))
                .map(|k| k.name())
                .collect();
            if !missing.is_empty() {
                cx.error(
                    t.span(),
                    format!(
                        "`thesis_figures` needs the methods {}: add {}",
                        names_and(&MethodKind::THESIS_FIGURES.map(MethodKind::name)),
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
        hamiltonian,
        regularize,
        params,
        q: q?,
        p: p?,
        t0,
        methods,
        duration: duration?,
        effects,
        events,
        ensemble,
        members,
        thesis_figures,
    })
}

/// The table `[name]` of the scene and its span; when it is missing, an error at the top of
/// the file (`missing table [name]: expected ...`) and an empty table.
fn table<T: Default>(
    t: Option<Spanned<T>>,
    name: &str,
    expected: &str,
    cx: &mut Ctxt<'_>,
) -> (Range<usize>, T) {
    match t {
        Some(t) => (t.span(), t.into_inner()),
        None => {
            cx.error(
                0..0,
                format!("missing table `[{name}]`: expected {expected}"),
            );
            (0..0, T::default())
        }
    }
}

/// The catalogue system `name` with the scene's parameters `given`: known names only,
/// defaults filled, required ones present, finite values, each within its declared rule
/// ([`ParamSpec::rule`]).
fn catalogue_system<'s>(
    system_name: &Spanned<String>,
    given: &BTreeMap<Spanned<String>, Spanned<f64>>,
    systems: &'s dyn SystemLookup,
    cx: &mut Ctxt<'_>,
) -> (String, Option<SystemInfo<'s>>, BTreeMap<String, f64>) {
    let name = system_name.get_ref().clone();
    let info = match systems.info(&name) {
        Some(info) => Some(info),
        None => {
            cx.error(
                system_name.span(),
                format!(
                    "unknown system `{name}`{}: expected one of {}",
                    did_you_mean(&name, systems.names().iter().copied()),
                    systems.names().join(", ")
                ),
            );
            None
        }
    };
    let mut params = BTreeMap::new();
    if let Some(info) = info {
        for (k, v) in given {
            if !info.params.iter().any(|p| p.name == k.get_ref().as_str()) {
                let expected: Vec<_> = info.params.iter().map(|p| p.name).collect();
                cx.error(
                    k.span(),
                    format!(
                        "unknown parameter `{}`{} of system `{name}`: expected {}",
                        k.get_ref(),
                        did_you_mean(k.get_ref(), expected.iter().copied()),
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
            } else if let Some(p) = info.params.iter().find(|p| p.name == k.get_ref().as_str()) {
                // The parameter's declared rule, at the value that breaks it.
                match p.check(&name, *v.get_ref()) {
                    Ok(v) => {
                        params.insert(k.get_ref().clone(), v);
                    }
                    Err(message) => cx.error(v.span(), message),
                }
            }
        }
        for p in info.params {
            if !params.contains_key(p.name) && !given.keys().any(|k| k.get_ref() == p.name) {
                match p.default {
                    // A default that breaks its own rule is the registration's mistake; it is
                    // reported at the system's name, where the scene chose the system.
                    Some(d) => match p.check(&name, d) {
                        Ok(d) => {
                            params.insert(p.name.to_string(), d);
                        }
                        Err(message) => cx.error(
                            system_name.span(),
                            format!("{message} (the default: give `{}` in `params`)", p.name),
                        ),
                    },
                    None => cx.error(
                        system_name.span(),
                        format!(
                            "system `{name}` needs parameter `{}` ({}): add it to `params`",
                            p.name, p.doc
                        ),
                    ),
                }
            }
        }
    }

    (name, info, params)
}

/// A Hamiltonian given as text (`source`, spanned in the scene file, with the parameters
/// `params` and the sizes `sizes`), read by the engine: the system's name `title`, its
/// metadata, the parameter values and the text system, or `None`s with the errors reported.
fn text_system(
    source: &Spanned<String>,
    params: &BTreeMap<Spanned<String>, Spanned<f64>>,
    sizes: &BTreeMap<Spanned<String>, Spanned<i64>>,
    title: String,
    cx: &mut Ctxt<'_>,
) -> (
    String,
    Option<SystemInfo<'static>>,
    BTreeMap<String, f64>,
    Option<TextHamiltonian>,
) {
    let (mut errors, mut warnings) = (Vec::new(), Vec::new());
    let checked = expression::check(cx.text, source, params, sizes, &mut errors, &mut warnings);
    for (span, message) in errors {
        cx.error(span, message);
    }
    match checked {
        Some((mut h, params)) => {
            h.warnings = warnings
                .into_iter()
                .map(|(span, message)| cx.locate(span, message))
                .collect();
            let info = text_info(&h);
            (title, Some(info), params, Some(h))
        }
        None => (title, None, BTreeMap::new(), None),
    }
}

/// What validation checks a Hamiltonian given as text against: the engine's dimension and
/// flags; no parameters to fill in, no period, exact solution or central force, and DTH
/// unless Psi is identically zero.
fn text_info(h: &TextHamiltonian) -> SystemInfo<'static> {
    SystemInfo {
        n: h.n,
        params: &[],
        time_dependent: h.time_dependent,
        has_period: false,
        has_exact: false,
        separable: h.separable,
        central_force: false,
        fixed_end_chain: false,
        dth: !h.psi_identically_zero,
        psi_identically_zero: h.psi_identically_zero,
        text: None,
        sizable: false,
    }
}

/// Why the text Hamiltonian `h` with parameter values `params` is not a chain whose normal
/// modes the `normal_modes` effect measures ([`crate::normal_modes::unit_chain_mismatch`] on
/// its gradient and Hessian at `z = 0`, evaluated by the engine's interpreter); `None` when
/// it is one.
fn text_chain_mismatch(h: &TextHamiltonian, params: &BTreeMap<String, f64>) -> Option<String> {
    if h.time_dependent {
        return Some("it depends on `t`".to_string());
    }
    let params: Vec<(&str, f64)> = params.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    let z = vec![0.0; h.dim];
    let mut g = vec![0.0; h.dim];
    let at_rest = RuntimeHamiltonian::with_backend(&h.source, &params, Backend::Interpreter)
        .and_then(|rt| {
            rt.gradient_slice(&z, &mut g)?;
            // A lattice that loops gives its nonzeros: its dense Hessian may not fit in
            // memory (512 MB at 4,096 sites).
            Ok(match rt.hessian_pattern() {
                Some(pattern) => {
                    let mut values = vec![0.0; pattern.len()];
                    rt.hessian_nonzeros_slice(&z, &mut values)?;
                    let entries = pattern.iter().zip(&values).map(|(&(i, j), &v)| (i, j, v));
                    crate::normal_modes::unit_chain_mismatch_sparse(h.n, &g, entries)
                }
                None => {
                    let mut hess = vec![0.0; h.dim * h.dim];
                    rt.hessian_slice(&z, &mut hess)?;
                    crate::normal_modes::unit_chain_mismatch(h.n, &g, &hess)
                }
            })
        });
    at_rest.unwrap_or_else(|e| Some(format!("its derivatives at z = 0 cannot be evaluated: {e}")))
}

/// The thesis's square of initial conditions (`[ensemble]` without `kind`).
fn square(
    e: super::raw::RawEnsemble,
    at: Range<usize>,
    n: Option<usize>,
    cx: &mut Ctxt<'_>,
) -> Option<Ensemble> {
    for (key, span) in members::present(&e) {
        if !members::SQUARE_KEYS.contains(&key) {
            cx.error(
                span,
                format!(
                    "`{key}` is not a key of the square ensemble: expected {} (or give `kind` = {})",
                    members::SQUARE_KEYS.join(", "),
                    members::KINDS
                ),
            );
        }
    }
    let mut required = |key: &str| {
        cx.error(
            at.clone(),
            format!(
                "missing field `{key}` of the square ensemble (keys {})",
                members::SQUARE_KEYS.join(", ")
            ),
        )
    };
    let (Some(ex), Some(ey), Some(hw), Some(ps), Some(st)) = (
        e.x.as_ref(),
        e.y.as_ref(),
        e.half_width.as_ref(),
        e.per_side.as_ref(),
        e.steps.as_ref(),
    ) else {
        for (key, given) in [
            ("x", e.x.is_some()),
            ("y", e.y.is_some()),
            ("half_width", e.half_width.is_some()),
            ("per_side", e.per_side.is_some()),
            ("steps", e.steps.is_some()),
        ] {
            if !given {
                required(key);
            }
        }
        return None;
    };
    let x = coord(ex, n, "x", cx);
    let y = coord(ey, n, "y", cx);
    for c in [(ex, x), (ey, y)] {
        if c.1 == Some(Coord::T) {
            cx.error(
                c.0.span(),
                "the ensemble varies q or p coordinates: expected q1..qn or p1..pn, not t",
            );
        }
    }
    if x.is_some() && x == y {
        cx.error(ey.span(), "the ensemble's `x` and `y` must differ");
    }
    let half_width = positive(hw, "half_width", cx);
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
    let per_side = count(ps, "per_side", 2, cx);
    let steps = count(st, "steps", 1, cx);
    Some(Ensemble {
        x: x?,
        y: y?,
        half_width: half_width?,
        per_side: per_side?,
        steps: steps?,
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
                "unknown method `{}`{}: expected one of {}",
                m.kind.get_ref(),
                did_you_mean(m.kind.get_ref(), names.iter().copied()),
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
            cx.error(dt.span(), "`dt` is not a key of method `dth`: expected `dtau` (the step in tau) and optionally `lambda0`, `solver`, `robust`, `order`");
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
            None => Some(Solver::default()),
            Some(s) => Solver::from_name(s.get_ref()).or_else(|| {
                let names: Vec<String> = Solver::ALL
                    .iter()
                    .map(|k| format!("\"{}\"", k.name()))
                    .collect();
                cx.error(
                    s.span(),
                    format!(
                        "unknown solver `{}`: expected {}",
                        s.get_ref(),
                        names_or(&names)
                    ),
                );
                None
            }),
        };
        let order = match &m.order {
            None => Some(2),
            Some(o) => u32::try_from(*o.get_ref())
                .ok()
                .filter(|&n| Composition::from_order(n).is_some())
                .or_else(|| {
                    cx.error(
                        o.span(),
                        format!(
                            "`order` = {}: expected 2, 4, 6 or 8 (DTH's order: 2 plain, 4-8 by symmetric composition)",
                            o.get_ref()
                        ),
                    );
                    None
                }),
        };
        StepSpec::Dth {
            dtau: dtau?,
            lambda0: lambda0?,
            solver: solver?,
            robust: m.robust.as_ref().is_some_and(|r| *r.get_ref()),
            order: order?,
            double_double: m.double_double.as_ref().is_some_and(|d| *d.get_ref()),
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
        let solver = m.solver.as_ref().map(|s| ("solver", s.span()));
        let robust = m.robust.as_ref().map(|r| ("robust", r.span()));
        let order = m.order.as_ref().map(|o| ("order", o.span()));
        let double_double = m
            .double_double
            .as_ref()
            .map(|d| ("double_double", d.span()));
        for (key, span) in solver
            .into_iter()
            .chain(robust)
            .chain(order)
            .chain(double_double)
        {
            cx.error(
                span,
                format!(
                    "`{key}` is a key of method `dth` only: `{}` takes `dt`",
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
    match Coord::from_name(s, n) {
        Some(c) => Some(c),
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
    cx: &mut Ctxt<'_>,
) -> Option<EffectSpec> {
    let e = e.into_inner();
    let Some(kind) = EffectKind::from_name(e.kind.get_ref()) else {
        let names: Vec<_> = EffectKind::ALL.iter().map(|k| k.name()).collect();
        cx.error(
            e.kind.span(),
            format!(
                "unknown effect `{}`{}: expected one of {}",
                e.kind.get_ref(),
                did_you_mean(e.kind.get_ref(), names.iter().copied()),
                names.join(", ")
            ),
        );
        return None;
    };
    let allowed = kind.keys();
    let present: [(&str, Option<Range<usize>>); 13] = [
        ("modes", e.modes.as_ref().map(|v| v.span())),
        ("every_time", e.every_time.as_ref().map(|v| v.span())),
        ("times", e.times.as_ref().map(|v| v.span())),
        ("period", e.period.as_ref().map(|v| v.span())),
        ("phase", e.phase.as_ref().map(|v| v.span())),
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
                        "`{key}` is not a key of effect `{}`: expected {}",
                        kind.name(),
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
                format!(
                    "effect `{}` needs `{what}` (a coordinate such as q1 or p1)",
                    kind.name()
                ),
            );
            None
        }
    };
    Some(match kind {
        EffectKind::FinalState => EffectSpec::FinalState,
        EffectKind::ComparisonTable => EffectSpec::ComparisonTable,
        EffectKind::Trajectory => EffectSpec::Trajectory {
            sampling: sampling(&e, every, cx)?,
        },
        EffectKind::Stroboscopic => {
            let period = match &e.period {
                Some(v) => positive(v, "period", cx),
                None => {
                    cx.error(
                        e.kind.span(),
                        "effect `stroboscopic` needs `period` (the drive's period: the section is at t = phase + j period)",
                    );
                    None
                }
            };
            let phase = match &e.phase {
                None => Some(0.0),
                Some(v) if v.get_ref().is_finite() && *v.get_ref() >= 0.0 => Some(*v.get_ref()),
                Some(v) => {
                    cx.error(
                        v.span(),
                        format!(
                            "`phase` = {}: expected a finite number >= 0 (the section is at t = phase + j period)",
                            v.get_ref()
                        ),
                    );
                    None
                }
            };
            let x = need(&e.x, "x", cx);
            let y = need(&e.y, "y", cx);
            EffectSpec::Stroboscopic {
                period: period?,
                phase: phase?,
                x: x?,
                y: y?,
            }
        }
        EffectKind::EnergyDeviation => EffectSpec::EnergyDeviation { every: every? },
        EffectKind::Invariants => EffectSpec::Invariants { every: every? },
        EffectKind::TimeLaw => EffectSpec::TimeLaw { every: every? },
        EffectKind::SpaceTime => EffectSpec::SpaceTime { every: every? },
        EffectKind::NormalModes => {
            let modes = match &e.modes {
                None => Some(n.map_or(5, |n| n.min(5))),
                Some(v)
                    if *v.get_ref() >= 1 && n.is_none_or(|n| *v.get_ref() as u64 <= n as u64) =>
                {
                    Some(*v.get_ref() as usize)
                }
                Some(v) => {
                    cx.error(
                        v.span(),
                        format!(
                            "`modes` = {}: expected an integer from 1 to {} (the chain's number of modes)",
                            v.get_ref(),
                            n.map_or("n".to_string(), |n| n.to_string())
                        ),
                    );
                    None
                }
            };
            EffectSpec::NormalModes {
                modes: modes?,
                every: every?,
            }
        }
        EffectKind::PhasePlot => {
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
        EffectKind::Poincare => {
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
    })
}

/// The `trajectory` effect's sampling: `every` steps (`every`, already checked: `None` when
/// it was bad), or one of `every_time`, `times` (a positive step; finite ascending times).
fn sampling(e: &RawEffect, every: Option<usize>, cx: &mut Ctxt<'_>) -> Option<Sampling> {
    let given: Vec<Range<usize>> = [
        e.every.as_ref().map(|v| v.span()),
        e.every_time.as_ref().map(|v| v.span()),
        e.times.as_ref().map(|v| v.span()),
    ]
    .into_iter()
    .flatten()
    .collect();
    if given.len() > 1 {
        cx.error(
            given[1].clone(),
            "give one of `every` (steps), `every_time` (a time step) or `times` (a list of times), not more",
        );
        return None;
    }
    if let Some(v) = &e.every_time {
        return positive(v, "every_time", cx).map(Sampling::EveryTime);
    }
    if let Some(v) = &e.times {
        let times = v.get_ref();
        if times.is_empty() {
            cx.error(v.span(), "`times` is empty: expected at least one time");
            return None;
        }
        if let Some(t) = times.iter().find(|t| !t.is_finite()) {
            cx.error(
                v.span(),
                format!("`times` holds {t}: expected finite times"),
            );
            return None;
        }
        if let Some(w) = times.windows(2).find(|w| w[0] >= w[1]) {
            cx.error(
                v.span(),
                format!(
                    "`times` must be ascending: {} is followed by {}",
                    w[0], w[1]
                ),
            );
            return None;
        }
        return Some(Sampling::Times(times.clone()));
    }
    every.map(Sampling::Steps)
}

/// A TOML or serde message in the scene's words: TOML's types where serde names Rust's
/// (`expected i64` is `expected an integer`, `map` a table, `sequence` an array), and an
/// integer beyond TOML's 64 bits said to be one (serde called it "invalid type: integer
/// `N` as i128").
fn plain_types(message: &str) -> String {
    let mut m = message.to_string();
    if let Some(rest) = m.strip_prefix("invalid type: integer `") {
        if let Some((digits, _)) = rest.split_once("` as i128") {
            return format!(
                "integer `{digits}` is out of range: TOML integers are 64-bit, from {} to {}",
                i64::MIN,
                i64::MAX
            );
        }
    }
    for (rust, toml) in [
        ("expected i64", "expected an integer"),
        ("expected f64", "expected a number"),
        ("expected a sequence", "expected an array"),
        ("invalid type: map,", "invalid type: table,"),
        ("invalid type: sequence,", "invalid type: array,"),
        ("expected a map", "expected a table"),
    ] {
        m = m.replace(rust, toml);
    }
    m
}

/// Table headers of the wrong kind, each at its line: `[method]` or `[effect]` for the arrays
/// of tables `[[method]]`, `[[effect]]`, and `[[system]]`, `[[initial]]`, `[[duration]]`,
/// `[[ensemble]]` for those single tables. Found before serde, whose messages for them name
/// types, not headers, and some at the top of the file.
fn header_mistakes(text: &str) -> Vec<(Range<usize>, String)> {
    let mut found = Vec::new();
    let mut at = 0;
    for line in text.split_inclusive('\n') {
        let header = line.split('#').next().unwrap_or("").trim();
        let start = at + line.len() - line.trim_start().len();
        at += line.len();
        let (one, many) = (
            header.strip_prefix('[').and_then(|h| h.strip_suffix(']')),
            header.strip_prefix("[[").and_then(|h| h.strip_suffix("]]")),
        );
        if let Some(name @ ("method" | "effect")) = one {
            found.push((
                start..start + header.len(),
                format!("`[{name}]` is one table, but a scene has a list of them: write `[[{name}]]`, once per {name}"),
            ));
        }
        if let Some(name @ ("system" | "initial" | "duration" | "ensemble")) = many {
            found.push((
                start..start + header.len(),
                format!(
                    "`[[{name}]]` makes a list of tables, but a scene has one: write `[{name}]`"
                ),
            ));
        }
    }
    found
}

/// `"a, b and c"`.
fn names_and(names: &[&str]) -> String {
    match names.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        _ => names.join(""),
    }
}

/// `"a, b or c"`.
fn names_or(names: &[String]) -> String {
    match names.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => names.join(""),
    }
}
