//! Lattices from text at full size: the FPUT-alpha chain with fixed ends as the one-line text
//! of `scenes/fput-4096.toml`, compiled at run time in loops (`dth_runtime`), against the
//! number of sites, and beside the macro's looped type of the same text at `N = 4096`. Then
//! what a scene's per-step effects add to a run of that scene. A plain timing table (no
//! criterion: a row takes seconds), one run, every row measured in it.
//!
//! Per `N = 64, 256, 512, 1024, 4096, 16384` (`D = 2N`):
//! - `compile`: `RuntimeHamiltonian::new` on the text (parse, derive the summands, plan and
//!   JIT the loops), the median of 3;
//! - `code`: the bytes of machine code the JIT wrote (`RuntimeHamiltonian::code_bytes`);
//! - `step`: one DTH step (`dtau = 0.1`) from a seeded state of the same local size at every
//!   `N` (displacements and momenta up to 0.1 per site, so the Newton iterations per step do
//!   not depend on `N`), the median of 3 rounds of `10^6 / N` steps (at least 20) after 20
//!   untimed steps; per site, the step divided by `N`;
//! - `iterations`: Newton iterations per step over the timed steps.
//!
//! At `N = 4096` the macro's looped type (`hamiltonian!` on the same text) runs the same
//! steps from the same state, its rounds alternating with the text's (so load on the machine
//! falls on both alike); both trajectories are checked to agree to roundoff first.
//!
//! Effects: `scenes/fput-4096.toml` run through `dth_examples::run_scene` for 1000 steps
//! (the whole run: compiling the text, stepping, writing the outputs and figures) with no
//! effect, with each of its effects alone at its default sampling (every step) and at the
//! scene's, and as shipped; the share an effect adds to the run without effects, the median
//! of 5 rounds that run every case in turn (after one untimed run).
//!
//! `cargo bench -p dth-examples --bench text_lattices` (release), numbers in
//! docs/performance.md.

mod timing;

use std::time::Duration;

use timing::{median, timed};

use dth::dth::{Dth, DthOptions};
use dth::nalgebra::{DVector, SVector};
use dth::Hamiltonian;
use dth_examples::catalogue::Catalogue;
use dth_examples::simulate::RunOptions;
use dth_runtime::RuntimeHamiltonian;

const SCENE: &str = include_str!("../scenes/fput-4096.toml");
const ALPHA: f64 = 0.25;
const DTAU: f64 = 0.1;

dth::hamiltonian! {
    /// The scene's chain, compiled by the macro (looped).
    pub struct Fput4096 { alpha: f64 } =
        sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3)
        where N = 4096, q[0] = q[N+1] = 0
}

/// The scene's Hamiltonian text with `N = n`.
fn text(n: usize) -> String {
    let line = SCENE
        .lines()
        .find_map(|l| l.strip_prefix("hamiltonian = \""))
        .and_then(|l| l.strip_suffix('"'))
        .expect("the scene's hamiltonian line");
    assert!(line.contains("where N = 4096"), "{line}");
    line.replace("where N = 4096", &format!("where N = {n}"))
}

/// A seeded state: displacements and momenta up to 0.1 at every site.
fn start(n: usize) -> Vec<f64> {
    let mut s = 0x5eed_u64;
    (0..2 * n)
        .map(|_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            0.1 * (2.0 * ((s >> 11) as f64 / (1u64 << 53) as f64) - 1.0)
        })
        .collect()
}

/// A DTH stepper on `h` from the seeded state, with 20 untimed steps taken.
fn stepper<D, H>(h: H, z0: dth::nalgebra::OVector<f64, D>) -> Dth<H, D>
where
    D: dth::nalgebra::Dim,
    H: Hamiltonian<D>,
    dth::nalgebra::DefaultAllocator: dth::Alloc<D>,
{
    let mut dth = Dth::new(h, z0, DthOptions::new(DTAU).expect("dtau")).expect("start");
    dth.advance(20).expect("untimed steps");
    dth
}

/// One round: the mean time of `steps` steps and the Newton iterations they took.
fn round<D, H>(dth: &mut Dth<H, D>, steps: usize) -> (Duration, u64)
where
    D: dth::nalgebra::Dim,
    H: Hamiltonian<D>,
    dth::nalgebra::DefaultAllocator: dth::Alloc<D>,
{
    let mut iterations = 0u64;
    let (_, elapsed) = timed(|| {
        for _ in 0..steps {
            iterations += u64::from(dth.step().expect("DTH step").iterations);
        }
    });
    (elapsed / steps as u32, iterations)
}

fn us(d: Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

/// The lattice rows; returns the text's and the macro's step at `N = 4096`.
fn lattice_rows() -> (Duration, Duration) {
    println!(
        "| N | D | compile (ms) | code (bytes) | loop-body ops | DTH step (ms) \
         | per site (us) | iterations / step |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let mut at_4096 = (Duration::ZERO, Duration::ZERO);
    for n in [64, 256, 512, 1024, 4096, 16384] {
        let src = text(n);
        let params = [("alpha", ALPHA)];
        let compile = median(
            (0..3)
                .map(|_| timed(|| RuntimeHamiltonian::new(&src, &params).expect("text")).1)
                .collect(),
        );
        let h = RuntimeHamiltonian::new(&src, &params).expect("text");
        let code = h.code_bytes().expect("compiled by the JIT");
        let ops = h.looped().expect("the sums loop").ops();
        let z0 = start(n);
        let steps = (1_000_000 / n).max(20);
        let mut text_dth = stepper(&h, DVector::from_vec(z0.clone()));
        let mut macro_dth =
            (n == 4096).then(|| stepper(Fput4096 { alpha: ALPHA }, SVector::from_vec(z0)));
        if let Some(m) = &macro_dth {
            // Equal results first: the same state after the untimed steps, to roundoff
            // (the macro's and the JIT's code are bit-identical on each evaluation; the
            // linear solves may round differently: 20 steps, each converged to a few eps of
            // the state, leave differences far below 1e-12).
            let (a, b) = (text_dth.zbar(), m.zbar());
            let scale = a.amax().max(1.0);
            let diff = (0..a.len())
                .map(|k| (a[k] - b[k]).abs())
                .fold(0.0, f64::max);
            assert!(diff <= 1e-12 * scale, "text and macro differ by {diff}");
        }
        let (mut text_times, mut macro_times, mut iterations) = (vec![], vec![], 0u64);
        for _ in 0..3 {
            let (t, it) = round(&mut text_dth, steps);
            text_times.push(t);
            iterations += it;
            if let Some(m) = &mut macro_dth {
                macro_times.push(round(m, steps).0);
            }
        }
        let step = median(text_times);
        println!(
            "| {n} | {} | {:.2} | {code} | {ops} | {:.3} | {:.3} | {:.2} |",
            2 * n,
            compile.as_secs_f64() * 1e3,
            step.as_secs_f64() * 1e3,
            us(step) / n as f64,
            iterations as f64 / (3 * steps) as f64,
        );
        if n == 4096 {
            at_4096 = (step, median(macro_times));
        }
    }
    at_4096
}

/// The seconds of one `run_scene` of `scene`.
fn scene_seconds(scene: &str, dir: &std::path::Path) -> f64 {
    let out = dir.join("out");
    let (result, elapsed) = timed(|| {
        dth_examples::run_scene(
            scene,
            "fput-4096.toml",
            &Catalogue::builtin(),
            &out,
            &RunOptions::default().with_progress(false),
        )
    });
    if let Err(e) = result {
        panic!("the scene failed: {e}");
    }
    elapsed.as_secs_f64()
}

fn effect_rows() {
    let effects_line = SCENE
        .lines()
        .find(|l| l.starts_with("effect = "))
        .expect("the scene's effect line");
    let base = SCENE.replace("steps = 10000", "steps = 1000");
    let with = |effects: &str| base.replace(effects_line, &format!("effect = [{effects}]"));
    // Each effect alone at its default sampling (every step) and at the scene's.
    let mut cases = vec![("none".to_string(), with(""))];
    for (kind, every) in [
        ("energy_deviation", 10),
        ("normal_modes", 50),
        ("space_time", 50),
    ] {
        cases.push((
            format!("{kind}, every step (default)"),
            with(&format!("{{ kind = \"{kind}\" }}")),
        ));
        cases.push((
            format!("{kind}, every {every} (the scene's)"),
            with(&format!("{{ kind = \"{kind}\", every = {every} }}")),
        ));
    }
    cases.push(("as shipped (all three)".to_string(), base.clone()));
    let dir = tempfile::tempdir().expect("a temporary directory");
    // One untimed run (first touches of the code and the allocator), then the cases in
    // turn, round after round, so a change of load falls on all of them alike.
    scene_seconds(&base, dir.path());
    let rounds = 5;
    let mut seconds = vec![Vec::new(); cases.len()];
    for _ in 0..rounds {
        for (k, (_, scene)) in cases.iter().enumerate() {
            seconds[k].push(Duration::from_secs_f64(scene_seconds(scene, dir.path())));
        }
    }
    let medians: Vec<f64> = seconds
        .into_iter()
        .map(|s| median(s).as_secs_f64())
        .collect();
    let none = medians[0];
    println!(
        "| effects (1000 DTH steps, N = 4096; median of {rounds}) | run (s) \
         | added to the run without effects |"
    );
    println!("|---|---|---|");
    for ((name, _), s) in cases.iter().zip(&medians) {
        let added = if name == "none" {
            "-".to_string()
        } else {
            format!("{:+.1}%", 100.0 * (s / none - 1.0))
        };
        println!("| {name} | {s:.2} | {added} |");
    }
}

fn main() {
    let (text, macro_step) = lattice_rows();
    println!();
    println!(
        "N = 4096, side by side: text {:.3} ms, macro {:.3} ms per DTH step: text / macro = {:.2}",
        text.as_secs_f64() * 1e3,
        macro_step.as_secs_f64() * 1e3,
        text.as_secs_f64() / macro_step.as_secs_f64()
    );
    println!();
    effect_rows();
}
