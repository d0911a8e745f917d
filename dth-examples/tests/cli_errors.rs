//! Each class of bad scene: exit code 2, `file:line:column` and what was expected, and no
//! output folder.

mod common;

use common::*;

const BASE: &str = "[system]
name = \"kepler\"
[initial]
q = [0.5, 0.0]
p = [0.0, 1.2]
[[method]]
kind = \"midpoint\"
dt = 0.001
[duration]
steps = 100
";

/// Writes `scene` as `bad.toml`, runs `dth run` and `dth check` on it, and checks both exit
/// with 2, name `bad.toml:line:col` and `expected`, and leave no output behind.
fn rejects(scene: &str, line_col: &str, expected: &str) {
    refuses(scene, 2, &[&format!("bad.toml:{line_col}: "), expected]);
}

/// Writes `scene` as `bad.toml`, runs `dth check` and `dth run` on it, and checks both exit
/// with `code`, say each of `expected` and leave no output behind.
fn refuses(scene: &str, code: i32, expected: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.toml"), scene).unwrap();
    for args in [
        &["check", "bad.toml"][..],
        &["run", "bad.toml", "--out", "out"],
    ] {
        let o = dth(args, dir.path());
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
        for expected in expected {
            assert!(
                err.contains(expected),
                "{args:?}: want `{expected}` in {err}"
            );
        }
        assert_eq!(entries(dir.path()), ["bad.toml"], "output left behind");
    }
}

#[test]
fn the_base_scene_is_valid() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("good.toml"), BASE).unwrap();
    let o = dth(&["check", "good.toml"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn unknown_key() {
    rejects(
        &format!("{BASE}[[effect]]\nkind = \"energy_deviation\"\nevry = 3\n"),
        "13:1",
        "unknown field `evry`, expected one of",
    );
    rejects(
        &format!("{BASE}[extra]\na = 1\n"),
        "11:2",
        "unknown field `extra`",
    );
}

#[test]
fn wrong_type() {
    rejects(
        &BASE.replace("steps = 100", "steps = \"many\""),
        "10:9",
        "invalid type: string \"many\", expected an integer",
    );
    rejects(
        &BASE.replace("q = [0.5, 0.0]", "q = 0.5"),
        "4:5",
        "invalid type: floating point `0.5`, expected an array",
    );
    // TOML's types, not Rust's (the messages said `i64`, `f64`, `map`, `sequence`).
    rejects(
        &BASE.replace("dt = 0.001", "dt = \"0.01\""),
        "8:6",
        "invalid type: string \"0.01\", expected a number",
    );
    // An integer beyond 64 bits was "invalid type: integer `N` as i128, expected an integer".
    rejects(
        &BASE.replace("steps = 100", "steps = 100000000000000000000"),
        "10:9",
        "integer `100000000000000000000` is out of range: TOML integers are 64-bit, from -9223372036854775808 to 9223372036854775807",
    );
}

/// `[method]` for `[[method]]`, or `[[initial]]` for `[initial]`: serde's messages named
/// types ("invalid type: map, expected a sequence"), `[[system]]`'s at line 1 whatever its
/// place. Each wrong header is now named at its line with the one to write.
#[test]
fn a_table_header_of_the_wrong_kind() {
    rejects(
        &BASE.replace("[[method]]", "[method]  # the integrator"),
        "6:1",
        "`[method]` is one table, but a scene has a list of them: write `[[method]]`, once per method",
    );
    let scene = format!(
        "title = \"x\"\n{}",
        BASE.replace("[initial]", "[[initial]]")
    );
    rejects(
        &scene,
        "4:1",
        "`[[initial]]` makes a list of tables, but a scene has one: write `[initial]`",
    );
    rejects(
        &format!(
            "title = \"x\"\n{}",
            BASE.replace("[system]", "  [[system]]")
        ),
        "2:3",
        "`[[system]]` makes a list of tables, but a scene has one: write `[system]`",
    );
}

#[test]
fn missing_initial_value() {
    rejects(
        &BASE.replace("p = [0.0, 1.2]\n", ""),
        "3:1",
        "missing initial value `p`: expected an array of 2 numbers",
    );
}

#[test]
fn dimension_mismatch() {
    rejects(
        &BASE.replace("q = [0.5, 0.0]", "q = [0.5, 0.0, 1.0]"),
        "4:5",
        "initial `q` has 3 values, but system `kepler` has n = 2 degrees of freedom: expected 2",
    );
}

#[test]
fn negative_or_zero_step() {
    rejects(
        &BASE.replace("dt = 0.001", "dt = -0.1"),
        "8:6",
        "`dt` = -0.1: expected a positive",
    );
    rejects(
        &BASE.replace("dt = 0.001", "dt = 0.0"),
        "8:6",
        "`dt` = 0: expected a positive",
    );
    let dth = BASE.replace(
        "kind = \"midpoint\"\ndt = 0.001",
        "kind = \"dth\"\ndtau = -0.06",
    );
    rejects(&dth, "8:8", "`dtau` = -0.06: expected a positive");
    rejects(
        &BASE.replace("steps = 100", "steps = 0"),
        "10:9",
        "expected a positive integer",
    );
}

/// A misspelled name is followed by the known name closest to it (none when nothing is
/// close: `leapfrog`, `energy` below).
#[test]
fn unknown_system() {
    rejects(
        &BASE.replace("\"kepler\"", "\"keplr\""),
        "2:8",
        "unknown system `keplr` (did you mean `kepler`?): expected one of kepler,",
    );
}

#[test]
fn unknown_effect() {
    rejects(
        &format!("{BASE}[[effect]]\nkind = \"energy\"\n"),
        "12:8",
        "unknown effect `energy`: expected one of final_state,",
    );
    rejects(
        &format!("{BASE}[[effect]]\nkind = \"energy_deviaton\"\n"),
        "12:8",
        "unknown effect `energy_deviaton` (did you mean `energy_deviation`?)",
    );
    rejects(
        &format!("{BASE}[[effect]]\nkind = \"phase_plot\"\nx = \"q3\"\ny = \"p1\"\n"),
        "13:5",
        "unknown coordinate `q3` for `x`: expected q1..q2, p1..p2 or t",
    );
}

#[test]
fn unknown_method() {
    rejects(
        &BASE.replace("midpoint", "leapfrog"),
        "7:8",
        "unknown method `leapfrog`: expected one of exact, dth,",
    );
    rejects(
        &BASE.replace("midpoint", "midpiont"),
        "7:8",
        "unknown method `midpiont` (did you mean `midpoint`?): expected one of exact,",
    );
    rejects(
        &BASE.replace("dt = 0.001", "dtau = 0.001"),
        "8:8",
        "`dtau` is a key of method `dth` only",
    );
}

#[test]
fn methods_only_where_they_apply() {
    rejects(
        &BASE
            .replace("\"kepler\"", "\"henon_heiles\"")
            .replace("midpoint", "discrete_mechanics"),
        "7:8",
        "method `discrete_mechanics` needs a central-force system",
    );
    rejects(
        &BASE
            .replace("\"kepler\"", "\"double_pendulum\"")
            .replace("midpoint", "stormer_verlet"),
        "7:8",
        "method `stormer_verlet` needs a separable H",
    );
}

#[test]
fn exact_solution_only_where_one_exists() {
    rejects(
        &BASE
            .replace("\"kepler\"", "\"henon_heiles\"")
            .replace("midpoint", "exact"),
        "7:8",
        "system `henon_heiles` has no exact solution",
    );
}

#[test]
fn unknown_parameter() {
    rejects(
        &BASE.replace(
            "name = \"kepler\"",
            "name = \"kepler\"\nparams = { mas = 1.0 }",
        ),
        "3:12",
        "unknown parameter `mas` of system `kepler`: expected one of m, k",
    );
    rejects(
        &BASE.replace(
            "name = \"kepler\"",
            "name = \"kepler\"\nparams = { K = 1.0 }",
        ),
        "3:12",
        "unknown parameter `K` (did you mean `k`?) of system `kepler`",
    );
}

#[test]
fn bad_ensemble() {
    rejects(
        &format!("{BASE}[ensemble]\nx = \"q1\"\ny = \"q1\"\nhalf_width = 0.1\nper_side = 1\nsteps = 25\n"),
        "15:12",
        "`per_side` = 1: expected an integer >= 2",
    );
    rejects(
        &format!("{BASE}[ensemble]\nx = \"q1\"\ny = \"p1\"\nhalf_width = 0.1\nper_side = 3\n"),
        "11:1",
        "missing field `steps`",
    );
}

#[test]
fn toml_syntax_error() {
    rejects("x = [1\n", "1:7", "unclosed array");
}

#[test]
fn every_independent_problem_is_reported_at_once() {
    let scene = BASE
        .replace("q = [0.5, 0.0]", "q = [0.5]")
        .replace("dt = 0.001", "dt = -1.0");
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.toml"), scene).unwrap();
    let o = dth(&["check", "bad.toml"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err.contains("bad.toml:4:5: initial `q` has 1 value"),
        "{err}"
    );
    assert!(err.contains("bad.toml:8:6: `dt` = -1"), "{err}");
}

#[test]
fn missing_scene_file_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(&["check", "nope.toml"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("cannot read scene `nope.toml`"));
    assert!(stderr(&o).contains("caused by:"));
}

#[test]
fn thesis_figures_need_kepler_and_the_thesis_methods() {
    rejects(
        &format!("thesis_figures = true\n{BASE}"),
        "1:18",
        "`thesis_figures` needs the methods exact, trapezoidal, midpoint, discrete_mechanics and dth: add exact, trapezoidal, discrete_mechanics, dth",
    );
    rejects(
        &format!(
            "thesis_figures = true\n{}",
            BASE.replace("\"kepler\"", "\"henon_heiles\"")
        ),
        "1:18",
        "expected a planar system with a period and an exact solution (kepler), not `henon_heiles`",
    );
}

/// `dth check` used to pass a pendulum with `m = 0` or `g < 0`, which `dth run` then refused
/// with exit 1: the parameter rules (`> 0`) are now validation's, at the offending value.
#[test]
fn parameter_outside_its_rule() {
    let pendulum = "[system]
name = \"pendulum\"
params = { m = 0.0 }
[initial]
q = [1.0]
p = [0.0]
[[method]]
kind = \"midpoint\"
dt = 0.01
[duration]
steps = 10
";
    rejects(
        pendulum,
        "3:16",
        "parameter `m` (mass) of system `pendulum` = 0: expected a positive number (> 0)",
    );
    rejects(
        &pendulum.replace("m = 0.0", "g = -9.81"),
        "3:16",
        "parameter `g` (gravity) of system `pendulum` = -9.81: expected a positive number (> 0)",
    );
    // Every broken rule at once, each at its value.
    rejects(
        &pendulum.replace("m = 0.0", "m = 0.0, l = 1.0, g = -9.81"),
        "3:34",
        "parameter `g` (gravity)",
    );
}

#[test]
fn check_prints_the_engines_warnings_for_a_text_hamiltonian_at_their_place() {
    // `q2` without `p2`: legal (exit 0), but the warning `hamiltonian!` gives as a compiler
    // warning, here at the token in the scene file: `q2` starts at byte 25 of the expression,
    // after the 15 characters of `hamiltonian = "` on line 2, so at column 41.
    let scene = "[system]
hamiltonian = \"p1^2/2 + q1^2/2 + eps*q1*q2\"
params = { eps = 0.5 }
[initial]
q = [0.5, 0.1]
p = [0.0, 0.0]
[[method]]
kind = \"midpoint\"
dt = 0.01
[duration]
steps = 10
";
    let engine = dth_symbolic::compile("p1^2/2 + q1^2/2 + eps*q1*q2", &["eps"]).unwrap();
    let expected = engine.warnings()[0].to_string();
    assert_eq!(engine.warnings()[0].span.start, 25);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("warns.toml"), scene).unwrap();
    let o = dth(&["check", "warns.toml"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert_eq!(err, format!("warning: warns.toml:2:41: {expected}\n"));
    // A text without anything suspicious, and a catalogue system: no warning.
    let clean = scene
        .replace("eps*q1*q2", "eps*q1^4")
        .replace("q = [0.5, 0.1]\np = [0.0, 0.0]", "q = [0.5]\np = [0.0]");
    std::fs::write(dir.path().join("clean.toml"), clean).unwrap();
    let o = dth(&["check", "clean.toml"], dir.path());
    assert_eq!((o.status.code(), stderr(&o)), (Some(0), String::new()));
}

/// A second `energy_deviation` (or any effect a run keeps one of) used to replace the first
/// silently (`every = 1` asked, `every = 2` written); a second identical figure or section
/// was computed twice. Both are now errors at the second one; different sections are fine.
#[test]
fn an_effect_asked_twice() {
    let twice = |a: &str, b: &str| format!("{BASE}[[effect]]\n{a}\n[[effect]]\n{b}\n");
    rejects(
        &twice(
            "kind = \"energy_deviation\"",
            "kind = \"energy_deviation\"\nevery = 2",
        ),
        "14:8",
        "effect `energy_deviation` is asked twice (first on line 12), and a run keeps one of it: remove one",
    );
    let section = "kind = \"poincare\"\ncoordinate = \"q2\"\nx = \"q1\"\ny = \"p1\"";
    rejects(
        &twice(section, section),
        "17:8",
        "effect `poincare` is asked twice (first on line 12) with the same keys: remove one",
    );
    let dir = tempfile::tempdir().unwrap();
    let other = section
        .replace("\"q2\"", "\"q1\"")
        .replace("\"q1\"\ny", "\"q2\"\ny");
    std::fs::write(dir.path().join("two.toml"), twice(section, &other)).unwrap();
    let o = dth(&["check", "two.toml"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Kepler at `q = 0`, or `sqrt(q1)` at `q1 < 0`: `dth check` passed, and `dth run` let every
/// method fail at its first step with a message about Newton residuals. Both now refuse the
/// state before anything runs (exit 2), naming H and its gradient there.
#[test]
fn an_initial_state_where_h_is_not_finite() {
    refuses(
        &BASE.replace("q = [0.5, 0.0]", "q = [0.0, 0.0]"),
        2,
        &["error: H is not finite at the initial state: H = NaN and grad H = [NaN, NaN, 0.0, 2.4] at q = [0.0, 0.0], p = [0.0, 1.2]: expected an initial state where `kepler` and its gradient are finite"],
    );
    let text = BASE
        .replace("name = \"kepler\"", "hamiltonian = \"p1^2/2 + sqrt(q1)\"")
        .replace("q = [0.5, 0.0]\np = [0.0, 1.2]", "q = [-1.0]\np = [0.0]");
    refuses(
        &text,
        2,
        &["H = NaN and grad H = [NaN, 0.0] at q = [-1.0], p = [0.0]"],
    );
    // Overflow: finite coordinates, H = inf; large values in exponent form.
    refuses(
        &BASE.replace("p = [0.0, 1.2]", "p = [0.0, 1e200]"),
        2,
        &["H = inf and grad H = [4.0, 0.0, 0.0, 2e200]"],
    );
}

/// `exact` on an unbound Kepler orbit after `midpoint`: `dth check` passed it, and `dth run`
/// computed the midpoint run, then stopped at `exact` and wrote nothing of it. Both now
/// refuse it before any method runs.
#[test]
fn a_method_that_cannot_run_is_refused_before_any_runs() {
    refuses(
        &BASE.replace("p = [0.0, 1.2]", "p = [0.0, 3.0]").replace(
            "[duration]",
            "[[method]]\nkind = \"exact\"\ndt = 0.01\n[duration]",
        ),
        1,
        &["error: method `exact` cannot run: this system has no exact solution for this initial state"],
    );
}

/// `time = 1e9` with `dt = 0.5` needs 2e9 steps: the run stopped at the cap of 1e8 steps, at
/// t = 5e7, and reported success (exit 0, nothing said). It is now refused before it runs.
#[test]
fn a_duration_in_time_beyond_the_step_cap() {
    refuses(
        &BASE
            .replace("dt = 0.001", "dt = 0.5")
            .replace("steps = 100", "time = 1e9"),
        2,
        &["method `midpoint` would need 2.000e9 steps of dt = 0.5 to reach t = 1000000000, more than the cap of 100000000 steps"],
    );
}

/// An output folder that cannot be created (its parent is a file) is the user's `--out`
/// being wrong, as a refused folder is: exit 2 with the system's reason (it was exit 1, an
/// I/O failure), and nothing written.
#[test]
fn an_output_folder_that_cannot_be_created() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("good.toml"), BASE).unwrap();
    std::fs::write(dir.path().join("file"), "").unwrap();
    let o = dth(&["run", "good.toml", "--out", "file/out"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("refusing to write to `file/out`: cannot create its parent folder `file`"),
        "{err}"
    );
    assert_eq!(entries(dir.path()), ["file", "good.toml"]);
}

/// A scene missing `[system]`, `[initial]` and `[duration]` got one error, for the first
/// (serde stops there); every missing table is now reported at once.
#[test]
fn every_missing_table_at_once() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("bare.toml"),
        "[[method]]\nkind = \"midpoint\"\ndt = 0.1\n",
    )
    .unwrap();
    let o = dth(&["check", "bare.toml"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for expected in [
        "bare.toml:1:1: missing table `[system]`: expected `name` (a catalogue system, see `dth list`) or `hamiltonian`",
        "bare.toml:1:1: missing table `[initial]`: expected `q` and `p`",
        "bare.toml:1:1: missing table `[duration]`: expected one of `steps`, `time`, `orbits`",
    ] {
        assert!(err.contains(expected), "want `{expected}` in {err}");
    }
    assert_eq!(err.lines().count(), 4, "one line per missing table: {err}");
}

/// The diagnostics of `dth check bad.toml` on `scene` (exit code 2), one per line.
fn diagnostics(scene: &str) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.toml"), scene).unwrap();
    let o = dth(&["check", "bad.toml"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    err.lines()
        .filter(|l| l.contains("bad.toml:"))
        .map(str::to_string)
        .collect()
}

/// A structural error (`step = 10` for `steps`) used to hide every other problem of the
/// file: serde stopped there. Now each is reported, and the missing duration that follows
/// from the misspelled key is not a second error.
#[test]
fn a_structural_error_hides_no_other() {
    let scene = BASE
        .replace("steps = 100", "step = 10")
        .replace("midpoint", "dht")
        .replace("p = [0.0, 1.2]", "p = [0.0, 1.2]\nqq = 1")
        + "[[effect]]\nkind = \"energy_deviation\"\nevry = 3\n";
    let found = diagnostics(&scene);
    for expected in [
        "bad.toml:6:1: unknown field `qq`",
        "bad.toml:11:1: unknown field `step`, expected one of `steps`, `time`, `orbits`",
        "bad.toml:14:1: unknown field `evry`",
        "bad.toml:8:8: unknown method `dht` (did you mean `dth`?)",
    ] {
        assert!(
            found.iter().any(|l| l.starts_with(expected)),
            "want `{expected}` in {found:#?}"
        );
    }
    assert_eq!(found.len(), 4, "{found:#?}");
}

/// `dht` for `dth`: two letters swapped are one edit, and get their "did you mean".
#[test]
fn a_swapped_method_name_gets_a_suggestion() {
    rejects(
        &BASE.replace("midpoint", "dht"),
        "7:8",
        "unknown method `dht` (did you mean `dth`?)",
    );
}

/// A bad row of a list ensemble's `members` is reported at the row (its bad value), every
/// one of them, not at the key and only the first.
#[test]
fn every_bad_member_row_at_its_place() {
    let scene = format!(
        "{BASE}[ensemble]\nkind = \"list\"\nmembers = \"\"\"\nq1, p2\n0.5, 1.2\n0.6, x\n0.7\n\"\"\"\n"
    );
    let found = diagnostics(&scene);
    for expected in [
        "bad.toml:16:6: `members` row 3: `x` is not a finite number",
        "bad.toml:17:1: `members` row 4 has 1 values: expected 2",
    ] {
        assert!(
            found.iter().any(|l| l.starts_with(expected)),
            "want `{expected}` in {found:#?}"
        );
    }
    assert_eq!(found.len(), 2, "{found:#?}");
}

/// `dtau = 1e-300` passed `check` and failed at step 1 with "singular newton matrix". A step
/// that cannot change the state in double precision is now refused by `check` and `run`,
/// with the smallest step that can.
#[test]
fn a_step_below_roundoff_is_refused_before_stepping() {
    let scene = BASE.replace(
        "kind = \"midpoint\"\ndt = 0.001",
        "kind = \"dth\"\ndtau = 1e-300",
    );
    refuses(
        &scene,
        2,
        &[
            "method `dth`: a step of dt = 1e-300 moves the initial state by about",
            "below what double precision resolves",
            "expected a step of at least",
        ],
    );
    // The bound is roundoff's: a small step that does change the state runs.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("small.toml"),
        BASE.replace("dt = 0.001", "dt = 1e-12"),
    )
    .unwrap();
    let o = dth(&["check", "small.toml"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// An ensemble whose member runs failed exited 0 with the count in the middle of its output.
/// It now ends with the error and exits 1, as a run whose method failed does.
#[test]
fn an_ensemble_with_failed_member_runs_says_so_last_and_exits_1() {
    let scene = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                 [[method]]\nkind = \"midpoint\"\ndt = 0.01\n[[method]]\nkind = \"exact\"\ndt = 0.01\n\
                 [duration]\nsteps = 10\n\
                 [ensemble]\nkind = \"grid\"\nx = \"p2\"\nx_range = [1.0, 3.0]\nx_count = 3\n";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("e.toml"), scene).unwrap();
    let o = dth(&["run", "e.toml", "--out", "out"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let last = err.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("error: 2 member runs (member and method) failed"),
        "{err}"
    );
    assert!(dir.path().join("out/ensemble.csv").is_file());
}

/// `dth derive --help` listed `--threads` and `--max-memory`, which do nothing there.
#[test]
fn derive_takes_no_run_limits() {
    let dir = tempfile::tempdir().unwrap();
    let help = stdout(&dth(&["derive", "--help"], dir.path()));
    assert!(help.contains("--param"), "{help}");
    assert!(
        !help.contains("--threads") && !help.contains("--max-memory"),
        "{help}"
    );
    let o = dth(&["derive", "p1^2/2", "--threads", "2"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let help = stdout(&dth(&["run", "--help"], dir.path()));
    assert!(
        help.contains("--threads") && help.contains("--max-memory"),
        "{help}"
    );
}

/// `derive` without `-p` reported `m` as an unknown variable without saying how to declare
/// it.
#[test]
fn derive_says_how_to_declare_a_parameter() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(&["derive", "p1^2/(2*m) + k*q1^2/2"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("unknown variable `m`"), "{err}");
    assert!(
        err.contains("if `m`, `k` are parameters, declare them with `-p m,k`"),
        "{err}"
    );
    let o = dth(
        &["derive", "p1^2/(2*m) + k*q1^2/2", "-p", "m,k"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn chosen_times() {
    let timed = BASE.replace("steps = 100", "time = 1.0");
    let effect = |scene: &str, keys: &str| format!("{scene}[[effect]]\n{keys}\n");
    rejects(
        &effect(BASE, "kind = \"trajectory\"\nevery_time = 0.1"),
        "12:8",
        "effect `trajectory` records states at chosen times, which a run of a number of steps does not reach exactly: give the duration as `time` or `orbits`",
    );
    rejects(
        &effect(&timed, "kind = \"trajectory\"\nevery = 2\nevery_time = 0.1"),
        "14:14",
        "give one of `every` (steps), `every_time` (a time step) or `times` (a list of times), not more",
    );
    rejects(
        &effect(&timed, "kind = \"trajectory\"\ntimes = [0.5, 0.2]"),
        "13:9",
        "`times` must be ascending: 0.5 is followed by 0.2",
    );
    rejects(
        &effect(&timed, "kind = \"trajectory\"\nevery_time = 0.0"),
        "13:14",
        "`every_time`",
    );
    rejects(
        &effect(&timed, "kind = \"stroboscopic\"\nx = \"q1\"\ny = \"p1\""),
        "12:8",
        "effect `stroboscopic` needs `period`",
    );
    // Known only once the run's end is: refused by `check` and `run` before any method runs.
    refuses(
        &effect(&timed, "kind = \"trajectory\"\ntimes = [0.5, 2.0]"),
        2,
        &["effect `trajectory` asks for the state at t = 2, outside the run from t = 0 to t = 1"],
    );
}

/// A reader that stops early (`dth derive ... | head -1`) ends `dth` quietly, by SIGPIPE as
/// other Unix tools end, not by a panic in `println!` with a backtrace on stderr.
#[cfg(unix)]
#[test]
fn a_closed_stdout_ends_dth_quietly() {
    use std::io::{BufRead, BufReader};
    use std::os::unix::process::ExitStatusExt;
    use std::process::{Command, Stdio};
    // Far more than a pipe's buffer (64 KB): `dth` is still printing when the reader goes.
    let lattice = "sum(i = 1..N, p[i]^2/2 + exp(q[i] - q[i+1])) where N = 300, q[N+1] = 0";
    let mut child = Command::new(env!("CARGO_BIN_EXE_dth"))
        .args(["derive", lattice])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("dth starts");
    let mut first = String::new();
    let stdout = child.stdout.take().expect("piped");
    BufReader::new(stdout)
        .read_line(&mut first)
        .expect("a line");
    assert!(first.starts_with("H = "), "{first}");
    // The reader is dropped here: the pipe is closed.
    let o = child.wait_with_output().expect("dth ends");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        o.status.signal(),
        Some(libc::SIGPIPE),
        "{:?}: {err}",
        o.status
    );
}
