//! Scenes that give their Hamiltonian as text (`[system] hamiltonian = "..."`): validation
//! reports the macro's messages at their place inside the scene file, and checks the scene's
//! state, methods and effects against what the engine derived.
//!
//! [`every_ui_case_has_a_scene_counterpart`]: every compile-fail case of `hamiltonian!`
//! (`tests/ui/*.rs`, read as `dth-runtime/tests/ui_counterparts.rs` reads them, through the
//! shared `tests/ui_cases`) that the engine reports at run time is put into a generated scene,
//! written in each of TOML's four string forms that can hold it (escapes, line
//! continuations and all), and validation must give the macro's messages in its order, each
//! at the line and column of the character the macro underlines, inside the string (a
//! parameter's at its key in `params`).
//!
//! The shipped scenes run: the Kepler scene ends where the built-in `kepler` does (as `Dyn`,
//! and at the fixed size `dth run` picks for it, bit for bit), and DTH
//! keeps the energy of Morse, forced Duffing and the 12-particle chain at its midpoints to
//! roundoff (shortened runs: the dev profile).

#[path = "../../tests/ui_cases/mod.rs"]
mod ui_cases;

use std::fs;

use dth::nalgebra::{DefaultAllocator, Dim};
use dth::runtime::Fixed;
use dth::Alloc;
use dth_examples::catalogue::Catalogue;
use dth_examples::error::SceneDiagnostic;
use dth_examples::runtime_system::{dispatch, MakeSystem, SceneText, TextJob, TextSystem};
use dth_examples::scene::{line_col, Duration, EffectSpec, MethodKind, Scene};
use dth_examples::simulate::{compute, MethodResult, RunOptions};
use dth_examples::system::SceneSystem;
use dth_examples::systems::Kepler;
use dth_examples::{check_scene, Error};
use ui_cases::{call, cases, diagnostics, macro_only};

/// The TOML string forms.
#[derive(Debug, Clone, Copy)]
enum Form {
    Basic,
    Literal,
    MultiLineBasic,
    MultiLineLiteral,
}

const FORMS: [Form; 4] = [
    Form::Basic,
    Form::Literal,
    Form::MultiLineBasic,
    Form::MultiLineLiteral,
];

/// `value` as a TOML string literal of `form`, with the offset in the literal of the
/// character that gives each byte of `value` (and one past the end); `None` when the form
/// cannot hold `value` (a literal string has no escapes).
///
/// An encoder written independently of the crate's decoder (`scene::toml_string`): basic
/// strings escape quotes, backslashes and control characters and write every non-ASCII
/// character as `\uHHHH` (or `\UHHHHHHHH`); multi-line basic strings break the line with a
/// continuation (`\`, newline, indentation: all dropped by TOML) before every word that
/// follows a space.
fn encode(value: &str, form: Form) -> Option<(String, Vec<usize>)> {
    let literal = matches!(form, Form::Literal | Form::MultiLineLiteral);
    let multi_line = matches!(form, Form::MultiLineBasic | Form::MultiLineLiteral);
    let control = |c: char| c.is_control() && c != '\t' && !(multi_line && c == '\n');
    if literal && value.chars().any(|c| c == '\'' || control(c)) {
        return None;
    }
    let (open, close) = match form {
        Form::Basic => ("\"", "\""),
        Form::Literal => ("'", "'"),
        // The newline after the opening delimiter is not part of the value.
        Form::MultiLineBasic => ("\"\"\"\n", "\"\"\""),
        Form::MultiLineLiteral => ("'''\n", "'''"),
    };
    let mut out = String::from(open);
    let mut offsets = Vec::new();
    let mut previous = None;
    for c in value.chars() {
        if matches!(form, Form::MultiLineBasic) && previous == Some(' ') && !c.is_whitespace() {
            out.push_str("\\\n    ");
        }
        offsets.extend(std::iter::repeat_n(out.len(), c.len_utf8()));
        match c {
            _ if literal => out.push(c),
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' if !multi_line => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c if control(c) || (!c.is_ascii() && !multi_line) => {
                if (c as u32) > 0xffff {
                    out.push_str(&format!("\\U{:08X}", c as u32));
                } else {
                    out.push_str(&format!("\\u{:04X}", c as u32));
                }
            }
            c => out.push(c),
        }
        previous = Some(c);
    }
    offsets.push(out.len());
    out.push_str(close);
    Some((out, offsets))
}

/// What follows `[system]` in every generated scene: a valid rest.
const REST: &str = "[initial]\nq = [0.0]\np = [0.0]\n[[method]]\nkind = \"midpoint\"\n\
                    dt = 0.1\n[duration]\nsteps = 1\n";

/// A scene with `hamiltonian = LITERAL` and `params` (each `"name" = 1.0`): its text, the
/// offset of the literal, and the offset of each parameter's key.
fn scene(literal: &str, params: &[&str]) -> (String, usize, Vec<usize>) {
    let mut text = String::from("[system]\nhamiltonian = ");
    let at = text.len();
    text.push_str(literal);
    text.push_str("\nparams = { ");
    let mut keys = Vec::new();
    for (i, p) in params.iter().enumerate() {
        if i > 0 {
            text.push_str(", ");
        }
        keys.push(text.len());
        text.push_str(&format!("{p:?} = 1.0"));
    }
    text.push_str(" }\n");
    text.push_str(REST);
    (text, at, keys)
}

/// The diagnostics of an invalid scene.
fn errors(text: &str) -> Vec<SceneDiagnostic> {
    match check_scene(text, "case.toml", &Catalogue::builtin()) {
        Err(Error::Scene(e)) => e.0,
        other => panic!("not a scene error: {other:?}\n{text}"),
    }
}

/// `line:column` of a byte offset.
fn at(text: &str, offset: usize) -> (usize, usize) {
    line_col(text, offset)
}

/// The words of an expression (for "parameter not used" checks).
fn words(expression: &str) -> Vec<&str> {
    expression
        .split(|c: char| !(c.is_alphanumeric() || c == '_'))
        .filter(|w| !w.is_empty())
        .collect()
}

#[test]
fn every_ui_case_has_a_scene_counterpart() {
    let mut failures = Vec::new();
    let mut checked = 0;
    for path in &cases() {
        let case = path.file_stem().unwrap().to_str().unwrap();
        let source = fs::read_to_string(path).unwrap();
        let stderr = fs::read_to_string(path.with_extension("stderr")).unwrap();
        let mut expected = diagnostics(&stderr, &source);
        expected.retain(|e| macro_only(case, &e.message).is_none());
        // `unbalanced-paren` does not tokenize as Rust (its counterpart is checked on the
        // line's text in `ui_counterparts`); an item the engine cannot see has no scene.
        let Some(call) = call(&source).filter(|_| case != "unbalanced-paren") else {
            continue;
        };
        // Scenes do not regularize (yet): the regularized cases have no scene.
        if call.regularize.is_some() {
            continue;
        }
        let names: Vec<&str> = call.params.iter().map(|(n, _)| n.as_str()).collect();
        let compiled = dth_symbolic::compile(&call.expression, &names);
        let mut duplicate = None;
        for (k, n) in names.iter().enumerate() {
            if names[..k].contains(n) {
                duplicate = Some(k);
            }
        }
        for form in FORMS {
            let Some((literal, offsets)) = encode(&call.expression, form) else {
                continue;
            };
            let (text, literal_at, keys) = scene(&literal, &names);
            let inside = literal_at..literal_at + literal.len();
            if let Some(k) = duplicate {
                // TOML has no repeated keys: the file is refused at the second one.
                let e = errors(&text);
                assert!(
                    e.len() == 1 && e[0].message.contains("duplicate key"),
                    "{case}: {e:?}"
                );
                assert_eq!((e[0].line, e[0].column), at(&text, keys[k]), "{case}");
                continue;
            }
            if compiled.is_ok() {
                // Warnings only: the expression is valid; nothing is reported inside it.
                if let Err(Error::Scene(e)) = check_scene(&text, "case.toml", &Catalogue::builtin())
                {
                    let start = at(&text, inside.start);
                    let end = at(&text, inside.end);
                    for d in &e.0 {
                        assert!(
                            (d.line, d.column) < start || (d.line, d.column) >= end,
                            "{case} ({form:?}): {d}"
                        );
                    }
                }
                continue;
            }
            checked += 1;
            let found = errors(&text);
            // A parameter the case declares but does not use is an error in a scene (as
            // `RuntimeHamiltonian::new` refuses it), not in the macro: it must name one.
            let (unused, found): (Vec<_>, Vec<_>) = found
                .into_iter()
                .partition(|d| d.message.ends_with("the Hamiltonian does not use it"));
            for d in &unused {
                assert!(
                    names.iter().any(|n| d.message.contains(&format!("`{n}`"))
                        && !words(&call.expression).contains(n)),
                    "{case}: {d}"
                );
            }
            let messages: Vec<&str> = found.iter().map(|d| d.message.as_str()).collect();
            let wanted: Vec<&str> = expected.iter().map(|e| e.message.as_str()).collect();
            if messages != wanted {
                failures.push(format!(
                    "{case} ({form:?}): {messages:?} instead of {wanted:?}"
                ));
                continue;
            }
            for (d, want) in found.iter().zip(&expected) {
                let offset = if let Some(k) = call.params.iter().position(|(_, a)| *a == want.start)
                {
                    // The macro points at the parameter in the struct; the scene at its key.
                    keys[k]
                } else if call.expression.trim().is_empty() {
                    // No token: the macro points at the call, the scene into the string.
                    literal_at + offsets[0]
                } else {
                    literal_at + offsets[want.start - call.at]
                };
                let want_at = at(&text, offset);
                if (d.line, d.column) != want_at {
                    failures.push(format!(
                        "{case} ({form:?}): `{}` at {}:{}, expected {}:{} (`{}`)\n{text}",
                        d.message,
                        d.line,
                        d.column,
                        want_at.0,
                        want_at.1,
                        text[offset..].chars().take(10).collect::<String>()
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // Most cases are errors the engine reports, most in every form.
    // Most cases are errors the engine reports (about 60), most in several forms (205 scenes
    // when this was written): a count far below says the cases were not read.
    assert!(checked >= 150, "{checked} scene counterparts");
}

/// A scene with `system` as its `[system]` table's body and `rest` after it.
fn with_system(system: &str, rest: &str) -> String {
    format!("[system]\n{system}\n{rest}")
}

const KEPLER: &str = "hamiltonian = \"(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)\"\n\
                      params = { m = 0.5, k = 1.0 }";

const PLANAR: &str = "[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n[[method]]\nkind = \"dth\"\n\
                      dtau = 0.1\n[[method]]\nkind = \"midpoint\"\ndt = 0.1\n\
                      [duration]\nsteps = 10\n";

fn messages(text: &str) -> Vec<String> {
    errors(text).iter().map(ToString::to_string).collect()
}

#[test]
fn the_dimension_and_flags_come_from_the_expression() {
    let scene = check_scene(
        &with_system(KEPLER, PLANAR),
        "k.toml",
        &Catalogue::builtin(),
    )
    .unwrap();
    let h = scene.hamiltonian.as_ref().unwrap();
    assert_eq!(
        (h.n, h.dim, h.separable, h.time_dependent),
        (2, 4, true, false)
    );
    assert!(!h.psi_identically_zero);
    assert_eq!(scene.params.get("m"), Some(&0.5));
    // Without `title`, the system is named by its expression.
    assert_eq!(
        scene.system,
        "H = (p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)"
    );
    assert_eq!(scene.title, scene.system);

    let forced = "title = \"forced\"\nhamiltonian = \"p1^2/2 + q1^2/2 - f*q1*cos(w*t)\"\n\
                  params = { f = 0.1, w = 1.3 }";
    let rest = PLANAR
        .replace("q = [0.5, 0.0]", "q = [1.0]\nt = 2.0")
        .replace("p = [0.0, 1.2]", "p = [0.0]");
    let scene = check_scene(&with_system(forced, &rest), "f.toml", &Catalogue::builtin()).unwrap();
    let h = scene.hamiltonian.as_ref().unwrap();
    assert_eq!((h.n, h.dim, h.time_dependent), (1, 4, true));
    assert_eq!((scene.system.as_str(), scene.t0), ("forced", 2.0));

    // The initial state's length is checked against the expression's n, at the array.
    let text = with_system(
        KEPLER,
        &PLANAR.replace("q = [0.5, 0.0]", "q = [0.5, 0.0, 0.1]"),
    );
    assert_eq!(
        messages(&text),
        ["k.toml:5:5: initial `q` has 3 values, but system `H = (p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)` has n = 2 degrees of freedom: expected 2"
            .replace("k.toml", "case.toml")]
    );
}

#[test]
fn name_and_hamiltonian_exclude_each_other() {
    let both = with_system(&format!("name = \"kepler\"\n{KEPLER}"), PLANAR);
    assert_eq!(
        messages(&both),
        ["case.toml:3:15: `[system]` takes `name` (a catalogue system) or `hamiltonian` (H as text), not both"]
    );
    let neither = with_system("params = { m = 1.0 }", PLANAR);
    assert_eq!(
        messages(&neither),
        ["case.toml:1:1: `[system]` needs `name` (a catalogue system, see `dth list`) or `hamiltonian` (H as text in the grammar of `hamiltonian!`)"]
    );
    let titled = with_system("name = \"kepler\"\ntitle = \"mine\"", PLANAR);
    assert_eq!(
        messages(&titled),
        ["case.toml:3:9: `title` names a Hamiltonian given as text (`hamiltonian`): a catalogue system is named by `name` (give the scene a `title` at the top instead)"]
    );
}

#[test]
fn methods_and_effects_are_checked_against_the_engines_flags() {
    // Psi identically zero: `dth` refused with the reason, the peers run.
    let free = "title = \"free\"\nhamiltonian = \"(p1^2 + p2^2)/2\"";
    let e = messages(&with_system(free, PLANAR));
    assert_eq!(e.len(), 1, "{e:?}");
    assert!(
        e[0].starts_with("case.toml:8:8: method `dth` cannot integrate system `free`: its Psi = (J gradH)^T HessH (J gradH) is identically zero"),
        "{e:?}"
    );
    // Separable-only methods check separability.
    let coupled = "title = \"coupled\"\nhamiltonian = \"(p1^2 + p2^2)/2 + q1^2*p2^2 + q2^2\"";
    let rest = PLANAR.replace("kind = \"midpoint\"", "kind = \"stormer_verlet\"");
    assert_eq!(
        messages(&with_system(coupled, &rest)),
        ["case.toml:11:8: method `stormer_verlet` needs a separable H = T(p) + V(q), which `coupled` is not: expected another method"]
    );
    // What a text H does not have: an exact solution, a central force, a period, quadratic
    // invariants, a fixed-end chain.
    let rest = PLANAR
        .replace("kind = \"dth\"\ndtau = 0.1", "kind = \"exact\"\ndt = 0.1")
        .replace("kind = \"midpoint\"", "kind = \"discrete_mechanics\"")
        .replace("steps = 10", "orbits = 2")
        + "[[effect]]\nkind = \"invariants\"\n[[effect]]\nkind = \"normal_modes\"\n";
    let e = messages(&with_system(&format!("title = \"K\"\n{KEPLER}"), &rest));
    let starts: Vec<&str> = e.iter().map(|m| &m[..m.find(": ").unwrap() + 2]).collect();
    assert_eq!(
        starts,
        [
            "case.toml:9:8: ",
            "case.toml:12:8: ",
            "case.toml:15:10: ",
            "case.toml:17:8: ",
            "case.toml:19:8: "
        ],
        "{e:?}"
    );
    assert!(e[0].contains("system `K` has no exact solution"), "{e:?}");
    assert!(e[1].contains("needs a central-force system"), "{e:?}");
    assert!(e[2].contains("`orbits` needs a known period"), "{e:?}");
    assert!(
        e[3].contains("a Hamiltonian given as text declares none: `K` has its energy only"),
        "{e:?}"
    );
    assert!(
        e[4].contains("effect `normal_modes` needs a chain with fixed ends"),
        "{e:?}"
    );
}

#[test]
fn parameters_are_checked_at_their_place() {
    // Used but not given: the engine's unknown variable, at the name inside the string; given
    // but not used, or not finite: at the key or value; a reserved name: at its key. All of
    // them at once, with the expression's own errors.
    let system =
        "hamiltonian = \"p1^2/(2*m) + k*q1^2/2 + 2**q1\"\nparams = { m = inf, c = 1.0, t = 2.0 }";
    assert_eq!(
        messages(&with_system(system, &PLANAR.replace("0.5, 0.0", "0.5").replace("0.0, 1.2", "1.2"))),
        [
            "case.toml:3:30: parameter `t` is a phase-space variable (q1..qN, p1..pN, t): parameters need their own names",
            "case.toml:2:29: unknown variable `k`: expected q1..qN, p1..pN, t, or a declared parameter",
            "case.toml:2:41: `**` is not an operator: powers are written with `^`, as in `2^q1`",
            "case.toml:3:16: parameter `m` = inf is not finite",
            "case.toml:3:21: unknown parameter `c`: the Hamiltonian does not use it",
        ]
    );
}

#[test]
fn the_shipped_text_scenes_are_valid() {
    let catalogue = Catalogue::builtin();
    let check = |name: &str| {
        let path = format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"));
        let text = fs::read_to_string(&path).unwrap();
        check_scene(&text, &path, &catalogue).unwrap_or_else(|e| panic!("{e}"))
    };
    let kepler = check("kepler-from-text.toml");
    let kinds: Vec<MethodKind> = kepler.methods.iter().map(|m| m.kind).collect();
    assert_eq!(kinds, [MethodKind::Dth, MethodKind::Midpoint]);
    assert_eq!(kepler.hamiltonian.unwrap().dim, 4);
    let morse = check("morse.toml").hamiltonian.unwrap();
    assert!(morse.separable && !morse.time_dependent);
    let duffing = check("duffing-forced.toml").hamiltonian.unwrap();
    assert_eq!((duffing.time_dependent, duffing.dim), (true, 4));
    let chain = check("chain-12.toml");
    let h = chain.hamiltonian.as_ref().unwrap();
    assert_eq!((h.n, h.separable), (12, true));
    // The multi-line string's line continuations are gone from the expression.
    assert!(!h.source.contains('\\'), "{}", h.source);
}

/// A shipped scene, validated.
fn shipped(name: &str) -> Scene {
    let path = scene_path(name);
    let text = fs::read_to_string(&path).unwrap();
    check_scene(&text, &path, &Catalogue::builtin()).unwrap_or_else(|e| panic!("{e}"))
}

fn quiet() -> RunOptions {
    RunOptions::default().with_progress(false)
}

/// Each method's final state.
fn final_states(results: &[MethodResult]) -> Vec<(String, Vec<f64>)> {
    results
        .iter()
        .map(|r| {
            assert!(r.failure.is_none(), "{}: {:?}", r.summary.label, r.failure);
            let end = r.summary.final_state.as_ref().expect("final_state");
            (r.summary.label.clone(), end.z.clone())
        })
        .collect()
}

#[test]
fn kepler_from_text_ends_where_the_builtin_kepler_does() {
    // The thesis's settings, 2,000 steps of each method (80 orbits of DTH).
    let mut scene = shipped("kepler-from-text.toml");
    scene.duration = Duration::Steps(2000);
    scene.effects = vec![EffectSpec::FinalState];
    let text = TextSystem::build(&scene).unwrap();
    let from_text = final_states(&compute(&text, &scene, &quiet()).unwrap());
    let builtin = Kepler {
        m: scene.params["m"],
        k: scene.params["k"],
    };
    let compiled = final_states(&compute(&builtin, &scene, &quiet()).unwrap());
    assert_eq!(from_text.len(), 2);
    for ((label, a), (_, b)) in from_text.iter().zip(&compiled) {
        // 1e-8 is the agreement the text path promises users (the same final states as the
        // built-in system to 1e-8), checked as such. The runtime programs are the macro's
        // (same operations, same order) and the Dyn stepper does the Const one's arithmetic,
        // so the states in fact agree to roundoff grown over the run, far inside it.
        let diff = a
            .iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(diff <= 1e-8, "{label}: {a:?} vs {b:?} ({diff:e})");
    }
}

#[test]
fn dth_keeps_the_energy_of_the_text_scenes_at_its_midpoints() {
    for (name, steps) in [
        ("morse.toml", 2000),
        ("duffing-forced.toml", 2000),
        ("chain-12.toml", 500),
    ] {
        let mut scene = shipped(name);
        scene.duration = Duration::Steps(steps);
        scene.effects = vec![EffectSpec::EnergyDeviation { every: 1 }];
        let system = TextSystem::build(&scene).unwrap();
        let results = compute(&system, &scene, &quiet()).unwrap();
        let dth = results
            .iter()
            .find(|r| r.summary.kind == "dth")
            .expect("a dth method");
        assert!(dth.failure.is_none(), "{name}: {:?}", dth.failure);
        let energy = dth.summary.energy.as_ref().expect("energy_deviation");
        assert_eq!(energy.points.count, steps, "{name}");
        // Roundoff: each H (calH for Duffing) and its terms are of order 1 here (Morse 0.28,
        // Duffing's terms below 2, the chain's 0.3 over 37 terms), so one evaluation rounds by
        // a few eps ~ 1e-16 and the energy condition is solved to that: 1e-14 is ~45 eps.
        assert!(energy.points.max <= 1e-14, "{name}: {:?}", energy.points);
        // The peers drift far above it (the scenes' comparison).
        let peers = results.iter().filter(|r| r.summary.kind != "dth");
        for p in peers {
            let e = p.summary.energy.as_ref().unwrap().points.max;
            assert!(
                e > 1e3 * energy.points.max.max(1e-17),
                "{name}: {} {e}",
                p.summary.label
            );
        }
    }
}

/// Which system type [`dispatch`] hands the pipeline.
struct SystemType;

impl TextJob for SystemType {
    type Output = &'static str;

    fn run<D: Dim, S: SceneSystem<D>>(self, _make: &MakeSystem<'_, S>) -> &'static str
    where
        DefaultAllocator: Alloc<D>,
    {
        std::any::type_name::<S>()
    }
}

#[test]
fn a_four_dimensional_text_runs_at_a_fixed_size_and_ends_where_the_builtin_kepler_does() {
    let mut scene = shipped("kepler-from-text.toml");
    assert_eq!(
        dispatch(&scene, SystemType).unwrap(),
        std::any::type_name::<Fixed<4>>()
    );
    let morse = shipped("morse.toml");
    assert_eq!(
        dispatch(&morse, SystemType).unwrap(),
        std::any::type_name::<SceneText>()
    );

    // What `dth run` runs on it, against the built-in system: 2,000 steps of each method.
    scene.duration = Duration::Steps(2000);
    scene.effects = vec![EffectSpec::FinalState];
    let text = Fixed::<4>::new(TextSystem::build(&scene).unwrap().0 .0).unwrap();
    let from_text = final_states(&compute(&text, &scene, &quiet()).unwrap());
    let builtin = Kepler {
        m: scene.params["m"],
        k: scene.params["k"],
    };
    let compiled = final_states(&compute(&builtin, &scene, &quiet()).unwrap());
    // Equal bits, stronger than the 1e-8 promised: the compiled programs perform the macro's
    // operations in its order (the same bits per evaluation) and both run the same
    // `Const<4>` stepper code, so nothing differs to round differently.
    assert_eq!(from_text, compiled);
}

/// The shipped `fput-4096.toml` with `[system] sizes = { N = n }` added: the same text, the
/// same formulas, another size.
fn fput_at(n: usize) -> String {
    shipped_at("fput-4096.toml", n)
}

/// The path of the shipped scene `file`.
fn scene_path(file: &str) -> String {
    format!("{}/scenes/{file}", env!("CARGO_MANIFEST_DIR"))
}

/// The shipped scene `file` with `[system] sizes = { N = n }` added.
fn shipped_at(file: &str, n: usize) -> String {
    let text = fs::read_to_string(scene_path(file)).unwrap();
    assert!(text.contains("[system]\n"));
    text.replacen(
        "[system]\n",
        &format!("[system]\nsizes = {{ N = {n} }}\n"),
        1,
    )
}

#[test]
fn the_4096_chain_scene_is_valid_at_its_size_and_its_formulas_fill_the_state() {
    let scene = shipped("fput-4096.toml");
    let h = scene.hamiltonian.as_ref().unwrap();
    assert_eq!((h.n, scene.q.len(), scene.p.len()), (4096, 4096, 4096));
    // q_i = 10 sin(i pi / (N + 1)): sin and the product round once each (a few eps of 10).
    for (k, &q) in scene.q.iter().enumerate() {
        let i = (k + 1) as f64;
        let want = 10.0 * (i * std::f64::consts::PI / 4097.0).sin();
        assert!(
            (q - want).abs() <= 4.0 * 10.0 * f64::EPSILON,
            "q{}: {q} {want}",
            k + 1
        );
    }
    assert!(scene.p.iter().all(|&p| p == 0.0));
    // The effects the scene asks for are all there (normal_modes was checked against the
    // unit chain by its nonzeros: no dense Hessian of D = 8192).
    let kinds: Vec<_> = scene.effects.iter().map(EffectSpec::kind).collect();
    assert!(
        kinds.contains(&dth_examples::scene::EffectKind::NormalModes),
        "{kinds:?}"
    );
    assert!(
        kinds.contains(&dth_examples::scene::EffectKind::SpaceTime),
        "{kinds:?}"
    );
}

#[test]
fn one_chain_scene_serves_every_size() {
    let text = fput_at(16);
    let mut scene =
        check_scene(&text, "fput-16.toml", &Catalogue::builtin()).unwrap_or_else(|e| panic!("{e}"));
    let h = scene.hamiltonian.as_ref().unwrap();
    assert_eq!((h.n, scene.q.len()), (16, 16));
    // Its title is the scene's; the system's name says the size the scene set.
    assert!(
        scene.system.ends_with("(sizes set by the scene: N = 16)"),
        "{}",
        scene.system
    );
    // N in the formula is the scene's 16, not the text's 4096.
    let want = 10.0 * (std::f64::consts::PI / 17.0).sin();
    assert!(
        (scene.q[0] - want).abs() <= 40.0 * f64::EPSILON,
        "{}",
        scene.q[0]
    );

    // A short run: DTH keeps the energy; space_time records every site (16 columns) every
    // 5 steps, its first row the initial positions themselves (groups of one site).
    scene.duration = Duration::Steps(40);
    scene.effects = vec![
        EffectSpec::EnergyDeviation { every: 1 },
        EffectSpec::SpaceTime { every: 5 },
    ];
    let system = TextSystem::build(&scene).unwrap();
    let results = compute(&system, &scene, &quiet()).unwrap();
    let dth = &results[0];
    assert!(dth.failure.is_none(), "{:?}", dth.failure);
    // H is about 0.3 here over 50 terms of order 1e-2..1: roundoff ~ a few eps of the
    // largest term, 1e-14 is ~45 eps.
    let energy = dth.summary.energy.as_ref().unwrap();
    assert!(energy.points.max <= 1e-14, "{:?}", energy.points);
    let rows = dth.outputs.space_time.as_ref().expect("space_time");
    assert_eq!(rows.len(), 40 / 5 + 1);
    assert_eq!(rows[0].q, scene.q);
    assert!(rows.iter().all(|r| r.q.len() == 16));
    assert!(rows.windows(2).all(|w| w[1].t > w[0].t));
}

/// The N-body scenes from one line (`calogero-256.toml`, `cluster-64.toml`: pair sums, looped),
/// at reduced sizes set by `sizes` (the cluster's start read from its CSV by column name, the
/// first bodies): DTH (robust for the collapsing cluster) keeps the energy at every midpoint
/// to roundoff.
#[test]
fn the_n_body_scenes_from_one_line_keep_their_energy() {
    for (file, n, dof) in [("calogero-256.toml", 16, 16), ("cluster-64.toml", 8, 24)] {
        let text = shipped_at(file, n);
        let mut scene = check_scene(&text, &scene_path(file), &Catalogue::builtin())
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!((scene.q.len(), scene.p.len()), (dof, dof), "{file}");
        let (q, p) = (&scene.q, &scene.p);
        // The magnitude of H's terms (kinetic, and every pair's), all summed: the scale of
        // the roundoff of H (each of `pairs + kinetic` additions rounds by eps of at most this).
        let kinetic: f64 = p.iter().map(|x| x * x / 2.0).sum();
        let (pairs, potential) = if file.starts_with("calogero") {
            let g2 = 0.25;
            let mut sum = 0.0;
            for i in 0..n {
                for j in i + 1..n {
                    sum += g2 / (q[i] - q[j]).powi(2);
                }
            }
            (n * (n - 1) / 2, sum)
        } else {
            let mut sum = 0.0;
            for i in 0..n {
                for j in i + 1..n {
                    let d: f64 = (0..3).map(|c| (q[3 * i + c] - q[3 * j + c]).powi(2)).sum();
                    sum += 1.0 / d.sqrt();
                }
            }
            (n * (n - 1) / 2, sum)
        };
        let tolerance = (pairs + n) as f64 * f64::EPSILON * (kinetic + potential);
        scene.duration = Duration::Steps(40);
        let system = TextSystem::build(&scene).unwrap();
        let results = compute(&system, &scene, &quiet()).unwrap();
        let dth = &results[0];
        assert!(dth.failure.is_none(), "{file}: {:?}", dth.failure);
        let energy = dth.summary.energy.as_ref().unwrap();
        assert!(
            energy.points.max <= tolerance,
            "{file}: {:?}, tolerance {tolerance:e}",
            energy.points
        );
    }
}

/// The catalogue's N-body systems take their size from a scene, as its chains do.
#[test]
fn the_catalogues_n_body_systems_take_their_size_from_a_scene() {
    for (name, sizes, dof) in [("gravity_3d", 5, 15), ("calogero_moser", 12, 12)] {
        let text = format!(
            "method = [{{ kind = \"dth\", dtau = 0.01 }}]\n[system]\nname = \"{name}\"\n\
             sizes = {{ N = {sizes} }}\n[initial]\nq = \"2*i + 0.1*random\"\np = \"0\"\n\
             [duration]\nsteps = 10\n"
        );
        let scene = check_scene(&text, "n.toml", &Catalogue::builtin())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(scene.q.len(), dof, "{name}");
        assert_eq!(scene.system, format!("{name}, N = {sizes}"));
        let system = TextSystem::build(&scene).unwrap();
        let results = compute(&system, &scene, &quiet()).unwrap();
        assert!(
            results[0].failure.is_none(),
            "{name}: {:?}",
            results[0].failure
        );
    }
}

#[test]
fn space_time_groups_sites_beyond_its_column_limit() {
    // 600 sites in 256 columns: groups of 3 (the first 88) and 2 (the other 168).
    let groups: Vec<_> = dth_examples::effects::site_groups(600, 256).collect();
    assert_eq!(groups.len(), 256);
    assert_eq!(groups[0], 0..3);
    assert_eq!(groups[87], 261..264);
    assert_eq!(groups[88], 264..266);
    assert_eq!(groups[255].end, 600);
    assert!(groups.windows(2).all(|w| w[0].end == w[1].start));
}

#[test]
fn seeded_random_states_repeat_and_differ_by_seed() {
    let scene_with = |seed: u64| {
        let text = fput_at(8).replace(
            "p = \"0\"",
            &format!("p = \"0.01*(2*random - 1)\"\nseed = {seed}"),
        );
        check_scene(&text, "r.toml", &Catalogue::builtin()).unwrap_or_else(|e| panic!("{e}"))
    };
    let (a, b, c) = (scene_with(7), scene_with(7), scene_with(8));
    assert_eq!(a.p, b.p);
    assert_ne!(a.p, c.p);
    assert!(a.p.iter().all(|p| (-0.01..0.01).contains(p)), "{:?}", a.p);
    // The positions are the formula's, whatever the seed.
    assert_eq!(a.q, c.q);
}

#[test]
fn an_initial_state_from_a_csv_file_takes_its_last_row() {
    let dir = tempfile::tempdir().unwrap();
    let csv = "row,t,q1,q2,p1,p2\nvertex,0,1,2,3,4\nvertex,0.75,0.5,0.25,-1,-2\n";
    fs::write(dir.path().join("start.csv"), csv).unwrap();
    let text = with_system(
        KEPLER,
        &PLANAR.replace("q = [0.5, 0.0]\np = [0.0, 1.2]", "file = \"start.csv\""),
    );
    let path = dir.path().join("k.toml");
    let scene = check_scene(&text, path.to_str().unwrap(), &Catalogue::builtin())
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        (scene.q, scene.p, scene.t0),
        (vec![0.5, 0.25], vec![-1.0, -2.0], 0.75)
    );
    // A missing file is an error at `file`, naming the path.
    let missing = text.replace("start.csv", "nowhere.csv");
    let e = messages_at(&missing, path.to_str().unwrap());
    assert_eq!(e.len(), 1, "{e:?}");
    assert!(
        e[0].contains(":5:8: initial state file") && e[0].contains("nowhere.csv"),
        "{e:?}"
    );
}

/// Every message validation gives for `text` read as the file `file`.
fn messages_at(text: &str, file: &str) -> Vec<String> {
    match check_scene(text, file, &Catalogue::builtin()) {
        Ok(_) => Vec::new(),
        Err(Error::Scene(diags)) => diags.0.iter().map(ToString::to_string).collect(),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn lattice_scene_errors_are_reported_at_their_place() {
    let one = |from: &str, to: &str| {
        let text = fput_at(8).replace(from, to);
        let line = text.lines().position(|l| l.contains(to)).unwrap() + 1;
        let e = messages_at(&text, "bad.toml");
        assert_eq!(e.len(), 1, "{e:?}");
        (line, e[0].clone())
    };
    // A size the text does not use: at its key.
    let (line, e) = one("sizes = { N = 8 }", "sizes = { N = 8, M = 3 }");
    assert!(
        e.starts_with(&format!(
            "bad.toml:{line}:18: size `M` is not a name the Hamiltonian uses"
        )),
        "{e}"
    );
    // A formula's unknown name and the state itself: inside the string.
    let (line, e) = one("q = \"10*sin(i*", "q = \"10*sin(j*");
    assert!(
        e.starts_with(&format!("bad.toml:{line}:13: unknown variable `j`")),
        "{e}"
    );
    let (line, e) = one("(N+1))\"", "(N+1)) + q1\"");
    assert!(
        e.starts_with(&format!("bad.toml:{line}:27: initial `q` is a formula")),
        "{e}"
    );
    assert!(e.contains("`q1` is the state it defines"), "{e}");
}

#[test]
fn the_catalogues_chains_take_their_size_from_the_scene() {
    let scene_of = |system: &str| {
        format!(
            "[system]\n{system}\n[initial]\nq = \"0.1*sin(i*pi/(N+1))\"\np = \"0\"\n\
             [[method]]\nkind = \"dth\"\ndtau = 0.1\n[duration]\nsteps = 20\n\
             [[effect]]\nkind = \"normal_modes\"\n[[effect]]\nkind = \"final_state\"\n"
        )
    };
    let text = scene_of("name = \"fput_beta\"\nsizes = { N = 100 }\nparams = { beta = 0.5 }");
    let scene =
        check_scene(&text, "b.toml", &Catalogue::builtin()).unwrap_or_else(|e| panic!("{e}"));
    let h = scene
        .hamiltonian
        .as_ref()
        .expect("runs the catalogue's text");
    assert_eq!((h.n, scene.q.len()), (100, 100));
    assert_eq!(scene.system, "fput_beta, N = 100");
    assert_eq!(scene.params.get("beta"), Some(&0.5));
    // At its own size, with the default parameter, it is the compiled chain: the same run.
    let at_32 = scene_of("name = \"fput_beta\"\nsizes = { N = 32 }");
    let compiled = scene_of("name = \"fput_beta\"");
    let run = |text: &str| {
        let scene = check_scene(text, "b.toml", &Catalogue::builtin()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        Catalogue::builtin()
            .run(&scene, &dir.path().join("out"), &quiet())
            .unwrap_or_else(|e| panic!("{e:?}"));
        let summary: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(dir.path().join("out/summary.json")).unwrap())
                .unwrap();
        summary["methods"][0]["final_state"].clone()
    };
    let (a, b) = (run(&at_32), run(&compiled));
    assert!(!a.is_null());
    assert_eq!(a, b);
    // A system of fixed size says which ones take a size.
    let e = messages_at(&scene_of("name = \"kepler\"\nsizes = { N = 3 }"), "k.toml");
    assert!(
        e.iter().any(|m| m.contains("`kepler` has its own size")
            && m.contains("`fput_alpha`, `fput_beta`, `toda_fixed_ends`")),
        "{e:?}"
    );
}
