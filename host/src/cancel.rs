//! Stopping a long computation from another thread: the [`Cancel`] handle a
//! computation asks at its step boundaries, and the [`Interrupt`] that raises
//! it.
//!
//! `identify`, `diagnose` and `holdout` carry the handle in their fits'
//! options ([`FullOptions::cancel`]; a fit, and the linearisation made
//! about it, carry it on) and ask it at their step boundaries: each fit,
//! each Levenberg–Marquardt trial and round of a fit, each fold of a
//! cross-validation, each candidate effect scored, each prior scale and
//! orientation weight chosen, each stage of a diagnosis; and within a pass
//! over the rows, at each chunk of the rows (the normal equations' chunks,
//! the linearisation's Jacobian, zeroed a few columns at a time, and its
//! pieces, the rows sorted into configurations, the deleted residuals'
//! blocks, the candidates' gravity torques, a diagnosis' tool points), so
//! that on 10⁵ rows the longest step between two questions is tens of ms.
//! It stands under every other module, [`crate::session`] included, so
//! that the session's own passes over the rows ask it too. Raised,
//! the computation ends with [`Cancelled`] and its caller drops what it had
//! (a pass asked to stop part way leaves partial sums, a linearisation
//! asked while its Jacobian is made is of no pose: the next
//! question discards them); never raised ([`Cancel::NEVER`], the default),
//! nothing changes: the question is one atomic load.
//!
//! The command line never raises one (SIGINT ends the process at once); the
//! Python package raises it on Ctrl-C and waits for the computation to stop.
//!
//! A `Cancel` is `Copy` and `'static`, so that it rides in options that are
//! `Copy` themselves. It reads a flag that lives as long as the program: each
//! [`Interrupt`] takes one from a pool and gives it back, lowered, when it is
//! dropped, so the flags are as many as the interrupts ever alive at once.
//!
//! [`FullOptions::cancel`]: crate::calibration::fit::FullOptions::cancel

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

/// The rows a pass of kinematics over the rows (a row's forward kinematics,
/// its chain, its configuration) computes between two questions to the
/// caller's request to stop: a few ms.
pub const ROWS: usize = 4096;

/// Whether the caller asked a computation to stop: asked at its step
/// boundaries ([`Cancel::check`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct Cancel(Option<&'static AtomicBool>);

/// A computation stopped because its caller asked ([`Cancel`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("the computation was cancelled")]
pub struct Cancelled;

impl Cancel {
    /// Never raised: what the command line runs with.
    pub const NEVER: Self = Self(None);

    /// Whether the caller asked to stop.
    pub fn requested(self) -> bool {
        self.0.is_some_and(|flag| flag.load(Ordering::Relaxed))
    }

    /// Whether the caller asked to stop, asked at row `row` of a pass over
    /// the rows only every [`ROWS`] rows (false between): the question of a
    /// pass that computes a row's kinematics, a few ms apart.
    pub fn requested_at(self, row: usize) -> bool {
        row.is_multiple_of(ROWS) && self.requested()
    }

    /// [`Cancelled`] once the caller asked to stop.
    pub fn check(self) -> Result<(), Cancelled> {
        if self.requested() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }
}

/// The flags of the interrupts dropped, lowered, for the next ones.
static FREE: Mutex<Vec<&'static AtomicBool>> = Mutex::new(Vec::new());

/// The caller's side of a [`Cancel`]: [`Interrupt::raise`] makes every
/// `Cancel` it gave ([`Interrupt::cancel`]) requested.
///
/// Its flag goes back to the pool when it is dropped: keep it alive (share
/// it, in an `Arc`, with the thread that computes) as long as anything may
/// read a `Cancel` it gave, or that `Cancel` would read a later interrupt's.
#[derive(Debug)]
pub struct Interrupt {
    flag: &'static AtomicBool,
}

impl Interrupt {
    /// An interrupt not raised.
    pub fn new() -> Self {
        let reused = FREE.lock().ok().and_then(|mut free| free.pop());
        Self {
            flag: reused.unwrap_or_else(|| Box::leak(Box::new(AtomicBool::new(false)))),
        }
    }

    /// The handle the computation asks.
    pub fn cancel(&self) -> Cancel {
        Cancel(Some(self.flag))
    }

    /// Asks every computation holding [`Interrupt::cancel`] to stop.
    pub fn raise(&self) {
        self.flag.store(true, Ordering::Relaxed);
    }
}

impl Default for Interrupt {
    fn default() -> Self {
        Self::new()
    }
}

impl Drop for Interrupt {
    fn drop(&mut self) {
        self.flag.store(false, Ordering::Relaxed);
        if let Ok(mut free) = FREE.lock() {
            free.push(self.flag);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A handle is requested once its interrupt is raised, never before; a
    /// dropped interrupt's flag, reused, starts lowered; `NEVER` never is.
    #[test]
    fn a_raised_interrupt_is_requested_and_a_reused_flag_starts_lowered() {
        let interrupt = Interrupt::new();
        let cancel = interrupt.cancel();
        assert_eq!(cancel.check(), Ok(()));
        interrupt.raise();
        assert!(cancel.requested());
        assert_eq!(cancel.check(), Err(Cancelled));
        drop(interrupt);
        let next = Interrupt::new();
        assert!(!next.cancel().requested());
        assert!(!Cancel::NEVER.requested() && !Cancel::default().requested());
    }
}
