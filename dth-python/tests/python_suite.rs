//! Runs the Python package's test suite (`dth-python/tests/test_*.py`) from `cargo test`, so
//! the README's test command covers it: a virtual environment under the target directory
//! gets the pinned tools of `requirements-test.txt` from the Python registry (once), the
//! package is staged into it, and pytest runs the suite. The Python interpreter is `python3`
//! (or `$DTH_PYTHON`).
//!
//! The package is staged, not built by `maturin develop`: `cargo test --workspace` has already
//! compiled this crate's extension (the cdylib is a dependency of this test), and a second
//! build by maturin would select only this package's dependency features, so every shared
//! dependency (nalgebra, Cranelift, the engine) would be compiled again, about four minutes
//! of a CI run on two cores. The staged layout is the one the wheel has, read from
//! `pyproject.toml`'s `[tool.maturin]` (`python-source` and `module-name`), which is what
//! `pip install ./dth-python` builds with maturin.

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

/// `[tool.maturin]`'s `python-source` and `module-name` (e.g. `python` and `dth._dth`).
fn maturin_layout(crate_dir: &Path) -> (String, String) {
    let text = std::fs::read_to_string(crate_dir.join("pyproject.toml")).expect("pyproject.toml");
    let doc: toml::Table = text.parse().expect("pyproject.toml is TOML");
    let maturin = doc
        .get("tool")
        .and_then(|t| t.get("maturin"))
        .expect("pyproject.toml has [tool.maturin]");
    let get = |key: &str| {
        maturin
            .get(key)
            .and_then(|v| v.as_str())
            .unwrap_or_else(|| panic!("[tool.maturin] {key} is a string"))
            .to_string()
    };
    (get("python-source"), get("module-name"))
}

/// The extension cargo built for this test run: `lib<name>.so` (or the platform's form) in
/// the directory that holds this test's executable.
fn built_extension(lib_name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test's own path");
    let deps = exe.parent().expect("the test executable's directory");
    let file = format!(
        "{}{lib_name}{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    );
    let path = deps.join(&file);
    assert!(
        path.is_file(),
        "the extension {file} is not beside the test executable in {}: build it with \
         `cargo test -p dth-python` (which compiles the cdylib first)",
        deps.display()
    );
    path
}

/// Copies the package's pure-Python part and the extension into `stage/`, as the wheel lays
/// them out, and returns the directory to put on the path.
fn stage_package(crate_dir: &Path, stage: &Path) -> PathBuf {
    let (python_source, module_name) = maturin_layout(crate_dir);
    let (package, extension) = module_name
        .rsplit_once('.')
        .expect("module-name is package.extension");
    let source = crate_dir.join(&python_source).join(package);
    let target = stage.join(package);
    if target.exists() {
        std::fs::remove_dir_all(&target).expect("clearing the staged package");
    }
    std::fs::create_dir_all(&target).expect("creating the staged package");
    for entry in std::fs::read_dir(&source).expect("the package's Python sources") {
        let entry = entry.expect("a directory entry");
        let name = entry.file_name();
        let name = name.to_string_lossy();
        // Python files, stubs and the typing marker; not bytecode caches nor an extension a
        // `maturin develop` left in the source tree.
        let keep = name.ends_with(".py") || name.ends_with(".pyi") || name == "py.typed";
        if keep && entry.path().is_file() {
            std::fs::copy(entry.path(), target.join(&*name)).expect("copying a source");
        }
    }
    let suffix = if cfg!(windows) { ".pyd" } else { ".abi3.so" };
    std::fs::copy(
        built_extension(extension),
        target.join(format!("{extension}{suffix}")),
    )
    .expect("copying the extension");
    stage.to_path_buf()
}

/// The environment's `site-packages` directory.
fn site_packages(python: &Path) -> PathBuf {
    let out = Command::new(python)
        .args([
            "-c",
            "import sysconfig; print(sysconfig.get_paths()['purelib'])",
        ])
        .output()
        .expect("asking the environment for site-packages");
    assert!(out.status.success(), "site-packages: {out:?}");
    PathBuf::from(String::from_utf8_lossy(&out.stdout).trim())
}

#[test]
fn the_python_suite_passes() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let venv = tmp.join("dth-python-venv");
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
    // The package on the environment's path by a `.pth` file (as an editable install does;
    // mypy reads it too). `dth.pth` replaces the one an earlier `maturin develop` wrote.
    let stage = stage_package(crate_dir, &tmp.join("dth-python-stage"));
    let site = site_packages(&venv_python(&venv));
    std::fs::write(site.join("dth.pth"), format!("{}\n", stage.display())).expect("dth.pth");
    run(
        "the Python suite",
        Command::new(venv_python(&venv))
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
            .arg(crate_dir.join("tests"))
            .current_dir(crate_dir.join("tests")),
    );
}
