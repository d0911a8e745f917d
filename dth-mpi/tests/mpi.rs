//! With the `mpi` feature: `mpirun -n 2 dth-mpi run SCENE` writes the same bytes as one
//! rank. Needs OpenMPI's `mpirun` (`.ci/run` installs it); as root it also needs
//! `OMPI_ALLOW_RUN_AS_ROOT=1` and `OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1`, which this test sets.

use std::path::Path;
use std::process::Command;

#[path = "../../dth-examples/tests/common/files.rs"]
mod files;
use files::files;

const SCENE: &str = "title = \"HH ranks\"\n[system]\nname = \"henon_heiles\"\n\
    [initial]\nq = [0.0, 0.0]\np = [0.0, 0.0]\n\
    [ensemble]\nkind = \"grid\"\nx = \"q2\"\nx_range = [-0.4, 0.6]\nx_count = 7\n\
    y = \"p2\"\ny_range = [-0.45, 0.45]\ny_count = 6\nenergy = 0.125\nsolve = \"p1\"\nchaos = \"megno\"\n\
    [[method]]\nkind = \"dth\"\ndtau = 0.1\n[duration]\ntime = 50.0\n\
    [[effect]]\nkind = \"poincare\"\ncoordinate = \"q1\"\nx = \"q2\"\ny = \"p2\"\n";

fn mpirun(ranks: &str, dir: &Path, out: &str) {
    let o = Command::new("mpirun")
        .args([
            "-n",
            ranks,
            "--oversubscribe",
            env!("CARGO_BIN_EXE_dth-mpi"),
        ])
        .args(["run", "scene.toml", "--out", out, "--threads", "1"])
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .current_dir(dir)
        .output()
        .expect("mpirun (OpenMPI) must be installed to test the mpi feature");
    assert!(
        o.status.success(),
        "mpirun -n {ranks}: {}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn two_ranks_write_the_same_bytes_as_one() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), SCENE).unwrap();
    // Both write the same folder (its path is in summary.json), one after the other.
    mpirun("1", dir.path(), "out");
    let a = files(&dir.path().join("out"));
    mpirun("2", dir.path(), "out");
    let b = files(&dir.path().join("out"));
    assert!(a.contains_key("ensemble.csv") && a.contains_key("chaos_map_dth.png"));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (name, bytes) in &a {
        assert!(bytes == &b[name], "{name} differs between 1 and 2 ranks");
    }
    // Rank 1 wrote nothing of its own: no other folder, no staging left behind.
    let mut entries: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    entries.sort();
    assert_eq!(entries, ["out", "scene.toml"]);
}
