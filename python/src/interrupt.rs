//! Ctrl-C during a long computation: the computation runs on a thread of its
//! own while Python's main thread keeps handling its signals, and an
//! interrupt asks the computation's [`Cancel`] to stop at its next step.

use armcal::cancel::{Cancel, Interrupt};
use pyo3::prelude::*;

use crate::errors;

/// How often Python's main thread runs its signal handlers while a
/// computation runs: the latency of Ctrl-C, less the computation's own.
const SIGNAL_POLL: std::time::Duration = std::time::Duration::from_millis(10);

/// What an interrupted computation does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum OnInterrupt {
    /// It asks its [`Cancel`] between its steps and stops: the exception is
    /// raised once it has, so that nothing runs on after it.
    Stops,
    /// It has no way to stop: it finishes in the background and its result
    /// is dropped; the exception is raised at once.
    RunsOn,
}

/// Runs `work` on a thread of its own while this one, Python's main thread,
/// keeps handling its signals every [`SIGNAL_POLL`]. When a handler raises
/// (Ctrl-C: `KeyboardInterrupt`), `work`'s [`Cancel`] is requested and the
/// exception is raised as `on_interrupt` says: for work that stops, within
/// its longest step between two checks.
pub(crate) fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    on_interrupt: OnInterrupt,
    work: impl FnOnce(Cancel) -> T + Send + 'static,
) -> PyResult<T> {
    use std::sync::Arc;
    // The thread holds the interrupt as long as it runs: its flag is not
    // given to another call while the thread may read it.
    let interrupt = Arc::new(Interrupt::new());
    let held = interrupt.clone();
    let handle = std::thread::spawn(move || work(held.cancel()));
    let joined = |handle: std::thread::JoinHandle<T>| {
        handle
            .join()
            .map_err(|_| errors::failure("the computation stopped on an internal error"))
    };
    loop {
        if handle.is_finished() {
            return joined(handle);
        }
        if let Err(interrupt_error) = py.check_signals() {
            interrupt.raise();
            if on_interrupt == OnInterrupt::Stops {
                // Its result (a cancellation, or what it finished) is dropped.
                let _ = py.detach(|| handle.join());
            }
            return Err(interrupt_error);
        }
        py.detach(|| std::thread::sleep(SIGNAL_POLL));
    }
}
