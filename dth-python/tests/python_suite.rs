//! Runs the Python package's test suite (`dth-python/tests/test_*.py`) from `cargo test`, so
//! the README's test command covers it: a virtual environment under the target directory
//! gets the pinned tools of `requirements-test.txt` from the Python registry (once), maturin
//! builds and installs the package into it, and pytest runs the suite. The Python interpreter
//! is `python3` (or `$DTH_PYTHON`).

use std::path::{Path, PathBuf};
use std::process::Command;

fn run(what: &str, command: &mut Command) {
    let status = command
        .status()
        .unwrap_or_else(|e| panic!("{what}: could not start {command:?}: {e}"));
    assert!(status.success(), "{what} failed ({status}): {command:?}");
}

fn venv_python(venv: &Path) -> PathBuf {
    venv.join("bin").join("python")
}

#[test]
fn the_python_suite_passes() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let venv = Path::new(env!("CARGO_TARGET_TMPDIR")).join("dth-python-venv");
    let python = std::env::var("DTH_PYTHON").unwrap_or_else(|_| "python3".to_string());
    let requirements = crate_dir.join("requirements-test.txt");
    let stamp = venv.join("requirements-test.txt");
    let installed = std::fs::read_to_string(&stamp).ok();
    let wanted = std::fs::read_to_string(&requirements).expect("requirements-test.txt");
    if installed.as_deref() != Some(wanted.as_str()) {
        run(
            "creating the virtual environment",
            Command::new(&python)
                .args(["-m", "venv", "--clear"])
                .arg(&venv),
        );
        run(
            "installing the test requirements",
            Command::new(venv_python(&venv))
                .args([
                    "-m",
                    "pip",
                    "install",
                    "--quiet",
                    "--disable-pip-version-check",
                    "-r",
                ])
                .arg(&requirements),
        );
        std::fs::write(&stamp, &wanted).expect("writing the stamp");
    }
    // The extension, built in the dev profile (dependencies optimised) into the workspace's
    // target directory, and installed into the environment.
    run(
        "building the package",
        Command::new(venv.join("bin").join("maturin"))
            .args(["develop", "--quiet", "--manifest-path"])
            .arg(crate_dir.join("Cargo.toml"))
            .env("VIRTUAL_ENV", &venv),
    );
    run(
        "the Python suite",
        Command::new(venv_python(&venv))
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
            .arg(crate_dir.join("tests"))
            .current_dir(crate_dir.join("tests")),
    );
}
