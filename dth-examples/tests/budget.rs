//! The memory budget: the estimate is what the effects store (exactly, where the step count is
//! known), and a scene above the limit is refused by `check` and `run` before anything runs.

mod common;

use common::*;
use dth_examples::budget::estimate;
use dth_examples::catalogue::Catalogue;
use dth_examples::driver::Stop;
use dth_examples::simulate::{compute, RunOptions};
use dth_examples::systems::Kepler;

const EFFECTS: &str = "[[effect]]\nkind = \"final_state\"\n\
    [[effect]]\nkind = \"trajectory\"\nevery = 3\n\
    [[effect]]\nkind = \"energy_deviation\"\nevery = 2\n\
    [[effect]]\nkind = \"invariants\"\nevery = 5\n\
    [[effect]]\nkind = \"time_law\"\nevery = 7\n\
    [[effect]]\nkind = \"phase_plot\"\nx = \"q1\"\ny = \"p1\"\nevery = 4\n";

fn scene(steps: &str) -> String {
    format!(
        "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
         [[method]]\nkind = \"dth\"\ndtau = 0.06277\n\
         [[method]]\nkind = \"midpoint\"\ndt = 0.15\n\
         [duration]\nsteps = {steps}\n{EFFECTS}"
    )
}

#[test]
fn the_estimate_is_what_the_effects_store() {
    let text = scene("1000");
    let scene = dth_examples::check_scene(&text, "budget.toml", &Catalogue::builtin()).unwrap();
    let results = compute(
        &Kepler::thesis(),
        &scene,
        &RunOptions::default().with_progress(false),
    )
    .unwrap();
    let e = estimate(&Kepler::thesis(), &scene, Stop::steps(1000));
    for (r, (label, steps, bytes)) in results.iter().zip(&e.methods) {
        assert_eq!(&r.summary.label, label);
        assert_eq!(*steps, 1000);
        assert_eq!(*bytes, 8 * r.summary.stored_values as u64, "{label}");
    }
}

#[test]
fn a_scene_above_the_limit_is_refused_by_check_and_run() {
    let dir = tempfile::tempdir().unwrap();
    // 10^9 steps of two methods with per-step effects: hundreds of GB.
    std::fs::write(dir.path().join("huge.toml"), scene("1000000000")).unwrap();
    let o = dth(&["check", "huge.toml"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    let err = stderr(&o);
    assert!(
        err.contains("refusing to run: the effects would keep about"),
        "{err}"
    );
    assert!(err.contains("--max-memory"), "{err}");
    let o = dth(&["run", "huge.toml", "--out", "out"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("refusing to run"), "{}", stderr(&o));
    assert_eq!(entries(dir.path()), ["huge.toml"]);
    std::fs::remove_file(dir.path().join("huge.toml")).unwrap();
    // The largest step count a scene can give does not overflow the estimate into a pass.
    std::fs::write(dir.path().join("max.toml"), scene(&i64::MAX.to_string())).unwrap();
    let o = dth(&["check", "max.toml"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("refusing to run"), "{}", stderr(&o));
    // A lower limit refuses a small scene too, and `check` reports the estimate when it fits.
    std::fs::write(dir.path().join("small.toml"), scene("1000")).unwrap();
    let o = dth(&["check", "small.toml"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("effects keep about"), "{}", stdout(&o));
    let o = dth(&["check", "small.toml", "--max-memory", "10k"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    let o = dth(&["check", "small.toml", "--max-memory", "lots"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("is not a size"), "{}", stderr(&o));
    // Sizes as people write them: `4GB` was "unknown unit `B`"; `GiB` is 1024^3.
    for (size, limit) in [
        ("4G", "limit 4.0 GB"),
        ("4GB", "limit 4.0 GB"),
        ("4gb", "limit 4.0 GB"),
        ("4GiB", "limit 4.3 GB"),
        ("512MiB", "limit 536.9 MB"),
        ("200000B", "limit 200.0 kB"),
    ] {
        let o = dth(&["check", "small.toml", "--max-memory", size], dir.path());
        assert_eq!(o.status.code(), Some(0), "{size}: {}", stderr(&o));
        assert!(stdout(&o).contains(limit), "{size}: {}", stdout(&o));
    }
    let o = dth(&["check", "small.toml", "--max-memory", "4X"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("unknown unit in `4X`"),
        "{}",
        stderr(&o)
    );
}

/// An ensemble of 10^11 random members with no effect was estimated at 0 bytes: `check`
/// passed it and `run` aborted allocating the members (exit 134, its temporary folder left
/// behind). The members and their table now count, and the scene is refused before it runs.
#[test]
fn an_ensemble_too_large_for_memory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let members = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
         [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[duration]\nsteps = 10\n\
         [ensemble]\nkind = \"random\"\nx = \"q1\"\nx_range = [0.4, 0.6]\nsamples = 100000000000\n";
    // Two grid axes whose product overflows a 64-bit count.
    let grid = members.replace(
        "kind = \"random\"\nx = \"q1\"\nx_range = [0.4, 0.6]\nsamples = 100000000000",
        "kind = \"grid\"\nx = \"q1\"\nx_range = [0.4, 0.6]\nx_count = 9000000000000000000\n\
         y = \"p2\"\ny_range = [1.0, 1.2]\ny_count = 9000000000000000000",
    );
    for scene in [members.to_string(), grid] {
        std::fs::write(dir.path().join("many.toml"), scene).unwrap();
        for args in [
            &["check", "many.toml"][..],
            &["run", "many.toml", "--out", "out"],
        ] {
            let o = dth(args, dir.path());
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
            assert!(
                err.contains("refusing to run: the effects and the table of"),
                "{err}"
            );
            assert!(err.contains("fewer members"), "{err}");
            assert_eq!(entries(dir.path()), ["many.toml"], "output left behind");
        }
    }
}

/// `--max-memory 1e30T` became `u64::MAX` bytes (`as u64` saturates), a limit every estimate
/// passed, saturated ones included, and `run` panicked in `Vec::with_capacity` (exit 101, its
/// temporary folder left behind). Such a size is now a clap error naming the option; a
/// saturated estimate is refused under any limit; and members the allocator refuses (a limit
/// above what the machine has) are an error, not an abort.
#[test]
fn an_absurd_memory_limit_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let members = |samples: &str| {
        format!(
            "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
             [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[duration]\nsteps = 10\n\
             [ensemble]\nkind = \"random\"\nx = \"q1\"\nx_range = [0.4, 0.6]\nsamples = {samples}\n"
        )
    };
    std::fs::write(dir.path().join("many.toml"), members("100000000000")).unwrap();
    for size in ["1e30T", "18446744073709551615"] {
        let o = dth(&["run", "many.toml", "--max-memory", size], dir.path());
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("'--max-memory <MAX_MEMORY>'"), "{err}");
        assert!(
            err.contains("more bytes than a 64-bit count holds"),
            "{err}"
        );
    }
    // 10^16 members: an estimate of about 9 EB, within a limit of 18 EB, but far more than
    // the address space.
    std::fs::write(dir.path().join("many.toml"), members("10000000000000000")).unwrap();
    // `dth run SCENE` under a limit of 18 EB (above any machine's memory): exit 2 and its
    // error, which must say `what`.
    let refused_allocation = |scene: &str, what: &str| {
        let o = dth(
            &["run", scene, "--out", "out", "--max-memory", "18000000T"],
            dir.path(),
        );
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(what), "{err}");
    };
    refused_allocation(
        "many.toml",
        "cannot allocate the members of the ensemble (10000000000000000 of",
    );
    assert_eq!(entries(dir.path()), ["many.toml"], "output left behind");
    // The thesis's square of initial states with 5e9 per side: its square overflowed
    // `usize` in the estimate (a panic); now saturated, and refused.
    let square = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                  [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[duration]\nsteps = 10\n\
                  [ensemble]\nx = \"q1\"\ny = \"p1\"\nhalf_width = 0.01\nsteps = 5\n";
    std::fs::write(
        dir.path().join("square.toml"),
        format!("{square}per_side = 5000000000\n"),
    )
    .unwrap();
    let o = dth(&["check", "square.toml"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("would keep more than a 64-bit count of bytes"),
        "{err}"
    );
    // 10^8 per side: 10^16 states, within a limit of 18 EB, not within the address space.
    std::fs::write(
        dir.path().join("square.toml"),
        format!("{square}per_side = 100000000\n"),
    )
    .unwrap();
    refused_allocation(
        "square.toml",
        "cannot allocate the square of initial states",
    );
    assert_eq!(entries(dir.path()), ["many.toml", "square.toml"]);
    // The largest step count saturates the estimate: refused even under the largest limit.
    let scene = scene(&i64::MAX.to_string());
    let scene = dth_examples::check_scene(&scene, "max.toml", &Catalogue::builtin()).unwrap();
    let stop = Stop::steps(usize::MAX);
    let z0 = dth_examples::simulate::initial_state(&Kepler::thesis(), &scene).unwrap();
    assert!(matches!(
        dth_examples::budget::check(
            &Kepler::thesis(),
            &scene,
            (&z0, stop),
            u64::MAX,
            dth_examples::budget::Measure::Always
        ),
        Err(dth_examples::Error::MemoryLimit { .. })
    ));
}

/// DTH's step `lambda dtau` follows the state, and a regularized run's physical step is `|u|^2`
/// times its fictitious one: the shipped e = 0.99 scene starts at pericentre, where its step is
/// ~40x smaller than on average, so counting from the initial step estimated 7.5 MB for a run
/// that keeps 0.15 MB, and a limit between the two refused the run. The count now comes from
/// the average step of the probe's run: the estimate is within 5% of what the runs keep (the
/// probe is a run of order 2 over one orbit or up to 2,000 steps; the scenes' order-8 methods
/// and landings differ from it by a few steps), and that limit lets the run through while a
/// lower one still refuses it.
#[test]
fn a_dth_run_for_a_time_is_counted_from_its_average_step() {
    let dir = tempfile::tempdir().unwrap();
    let catalogue = Catalogue::builtin();
    let options = RunOptions::default().with_progress(false);
    for name in [
        "kepler-e099-regularized.toml",
        "kepler-e09-robust.toml",
        "three-body-close-approach.toml",
    ] {
        let text = std::fs::read_to_string(manifest_dir().join("scenes").join(name)).unwrap();
        std::fs::write(dir.path().join(name), &text).unwrap();
        let scene = dth_examples::check_scene(&text, name, &catalogue).unwrap();
        let estimate = catalogue.estimate(&scene, &options).unwrap();
        let out = format!("out-{name}");
        let o = dth(&["run", name, "--out", &out], dir.path());
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
        let summary: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join(&out).join("summary.json")).unwrap(),
        )
        .unwrap();
        let kept: u64 = summary["methods"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| 8 * m["stored_values"].as_u64().unwrap())
            .sum();
        let ratio = estimate.bytes() as f64 / kept as f64;
        assert!(
            (0.95..1.05).contains(&ratio),
            "{name}: estimated {estimate:?}, kept {kept} bytes"
        );
    }
    let name = "kepler-e099-regularized.toml";
    for (limit, code) in [("1MB", 0), ("100kB", 2)] {
        for command in ["check", "run"] {
            let out = format!("out-{limit}");
            let mut args = vec![command, name, "--max-memory", limit];
            if command == "run" {
                args.extend(["--out", &out]);
            }
            let o = dth(&args, dir.path());
            assert_eq!(
                o.status.code(),
                Some(code),
                "{command} at {limit}: {}",
                stderr(&o)
            );
        }
    }
}
