//! Long calls run on a worker thread without the GIL while the calling thread polls Python's
//! signal handlers: Ctrl-C (`KeyboardInterrupt`) sets the run's interrupt flag, the worker
//! stops at its next step, and the exception is raised once it has. A panic in the worker is
//! caught and becomes a `RuntimeError`, never crossing into Python.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::RecvTimeoutError;
use std::time::Duration;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// How often the calling thread wakes to run Python's signal handlers.
pub const POLL: Duration = Duration::from_millis(50);

/// Runs `job` on a worker thread without the GIL, raising `flag` (which the job polls) when
/// Python receives a signal whose handler raises (Ctrl-C); returns the job's result, or that
/// exception after the job has returned.
pub fn run<T, F>(py: Python<'_>, flag: &AtomicBool, job: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> T + Send,
{
    std::thread::scope(|scope| {
        let (sender, mut receiver) = std::sync::mpsc::channel();
        let worker = scope.spawn(move || {
            // A send fails only when the caller has gone, which it does not before joining.
            let _ = sender.send(job());
        });
        let mut raised = None;
        let received = loop {
            // The receiver is not `Sync`: moved in and back out.
            let (waited, back) = py.detach(move || (receiver.recv_timeout(POLL), receiver));
            receiver = back;
            match waited {
                Ok(result) => break Some(result),
                // The worker ended without a result: it panicked (joined below).
                Err(RecvTimeoutError::Disconnected) => break None,
                Err(RecvTimeoutError::Timeout) => {
                    if raised.is_none() {
                        if let Err(signal) = py.check_signals() {
                            flag.store(true, Ordering::Relaxed);
                            raised = Some(signal);
                        }
                    }
                }
            }
        };
        let joined = worker.join();
        if let Some(signal) = raised {
            return Err(signal);
        }
        match (received, joined) {
            (Some(result), _) => Ok(result),
            (None, Err(panic)) => Err(PyRuntimeError::new_err(format!(
                "internal error (a panic in dth): {}",
                panic_message(panic.as_ref())
            ))),
            (None, Ok(())) => Err(PyRuntimeError::new_err(
                "internal error: the run ended without a result",
            )),
        }
    })
}

/// A panic's message, when it has one.
fn panic_message(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_string())
}
