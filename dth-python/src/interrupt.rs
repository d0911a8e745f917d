//! Long calls run on a worker thread without the GIL while the calling thread polls Python's
//! signal handlers: Ctrl-C (`KeyboardInterrupt`) sets the run's interrupt flag, the worker
//! stops at its next step, and the exception is raised once it has. A panic in the worker is
//! caught and becomes a `RuntimeError`, never crossing into Python.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// How often the calling thread wakes to run Python's signal handlers.
pub const POLL: Duration = Duration::from_millis(50);

/// Runs `job(flag)` on a worker thread without the GIL, `flag` raised when Python receives a
/// signal whose handler raises (Ctrl-C); returns the job's result, or that exception after the
/// job has returned.
pub fn run<T, F>(py: Python<'_>, job: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&AtomicBool) -> T + Send,
{
    let flag = AtomicBool::new(false);
    let caller = std::thread::current();
    std::thread::scope(|scope| {
        let worker = scope.spawn(|| {
            // Wakes the caller when done, whatever the job did (the guard runs on unwind too).
            struct Wake(std::thread::Thread);
            impl Drop for Wake {
                fn drop(&mut self) {
                    self.0.unpark();
                }
            }
            let _wake = Wake(caller);
            job(&flag)
        });
        let mut raised = None;
        while !worker.is_finished() {
            py.detach(|| {
                if !worker.is_finished() {
                    std::thread::park_timeout(POLL);
                }
            });
            if raised.is_none() {
                if let Err(signal) = py.check_signals() {
                    flag.store(true, Ordering::Relaxed);
                    raised = Some(signal);
                }
            }
        }
        let result = worker.join().map_err(|panic| {
            let message = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            PyRuntimeError::new_err(format!("internal error (a panic in dth): {message}"))
        })?;
        match raised {
            Some(signal) => Err(signal),
            None => Ok(result),
        }
    })
}
