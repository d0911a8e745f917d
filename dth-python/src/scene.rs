//! `dth.run_scene`'s Rust half: runs a scene as the `dth run` command does, into a folder,
//! without the GIL and interruptible. The Python half (`python/dth/scenes.py`) picks the folder
//! (a temporary one unless the caller gives `out`) and reads back `summary.json` and the CSV
//! files as a dict and numpy arrays.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

use dth_examples::catalogue::Catalogue;
use dth_examples::simulate::RunOptions;
use dth_examples::RunError;

create_exception!(
    dth,
    SceneError,
    PyValueError,
    "A scene that cannot run: a TOML or schema error (every problem, each at file:line:column), \
     an unknown system or method, or an output folder that may not be replaced."
);

/// Runs scene `text` (named `file` in messages) into the folder `out`; returns whether every
/// method completed and the folder written: `out`, or beside it (`out.incomplete`) when an
/// incomplete run would have replaced a complete earlier result there. A method that failed
/// mid-run is not an exception: its outputs are written and `summary.json` says what stopped
/// it.
#[pyfunction]
#[pyo3(signature = (text, file, out, threads = None))]
pub fn run_scene_into(
    py: Python<'_>,
    text: &str,
    file: &str,
    out: PathBuf,
    threads: Option<usize>,
) -> PyResult<(bool, PathBuf)> {
    // The scene runner takes a flag that lives as long as the program (`RunOptions` holds a
    // `&'static AtomicBool`): one byte per call, never freed.
    let interrupt: &'static AtomicBool = Box::leak(Box::new(AtomicBool::new(false)));
    let mut options = RunOptions::default()
        .with_progress(false)
        .with_interrupt(interrupt);
    if let Some(threads) = threads {
        if threads == 0 {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        options = options.with_threads(threads);
    }
    let result = crate::interrupt::run(py, interrupt, || {
        dth_examples::run_scene(text, file, &Catalogue::builtin(), &out, &options).map_err(Box::new)
    })?;
    match result {
        Ok(report) => Ok((true, report.out)),
        Err(e) => match *e {
            RunError::NotRun(error) => Err(SceneError::new_err(error_chain(&error))),
            RunError::MethodsFailed { report } => Ok((false, report.out)),
            RunError::Interrupted { .. } => {
                Err(PyRuntimeError::new_err("the scene run was interrupted"))
            }
        },
    }
}

/// An error and its sources, one per line, as the `dth` command prints them.
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str("\n  caused by: ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    text
}
