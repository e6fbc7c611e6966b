//! A compute deadline shared by the workers of one query: a simulation
//! or a collision query.
//!
//! Reading the clock costs tens of nanoseconds, a frustum or a pair of
//! leaves some hundreds: workers read it every [`CLOCK_PERIOD`] units of
//! work. The first to see it passed raises a flag that every other worker
//! reads on each unit (one relaxed load of a line nobody writes until
//! then), so all stop within one unit of each other.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use crate::{Error, Result};

/// Units of work (frusta, pairs of leaves) between two readings of the
/// clock by one worker.
pub(crate) const CLOCK_PERIOD: u64 = 64;

/// Stops a running simulation from another thread: it returns
/// [`Error::Cancelled`] within a frustum or so of [`Cancel::cancel`]. For
/// work whose client has gone (a stream that closed).
#[derive(Clone, Debug, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

pub(crate) struct Deadline {
    at: Option<Instant>,
    /// The limit as the caller granted it, for the error message.
    limit_ms: u64,
    expired: AtomicBool,
    cancel: Option<Cancel>,
}

impl Deadline {
    /// No deadline: never expires.
    pub fn none() -> Self {
        Self::new(None, Instant::now())
    }

    /// A deadline at `at`, for work that started at `start`.
    pub fn new(at: Option<Instant>, start: Instant) -> Self {
        let limit_ms = at.map_or(0, |at| {
            at.saturating_duration_since(start).as_millis() as u64
        });
        Self {
            at,
            limit_ms,
            expired: AtomicBool::new(false),
            cancel: None,
        }
    }

    /// The same deadline, also ending when `cancel` is cancelled.
    pub fn or_cancel(self, cancel: Option<&Cancel>) -> Self {
        Self {
            cancel: cancel.cloned(),
            ..self
        }
    }

    /// Reads the clock: an error once the deadline has passed.
    pub fn check(&self) -> Result<()> {
        if let Some(at) = self.at {
            if Instant::now() >= at {
                self.expired.store(true, Ordering::Relaxed);
            }
        }
        self.expired()
    }

    /// Only reads the flags: an error once a worker saw the deadline pass
    /// or the work was cancelled.
    #[inline]
    pub fn expired(&self) -> Result<()> {
        if self.cancel.as_ref().is_some_and(Cancel::is_cancelled) {
            return Err(Error::Cancelled);
        }
        if self.expired.load(Ordering::Relaxed) {
            Err(Error::DeadlineExceeded {
                limit_ms: self.limit_ms,
            })
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn a_passed_deadline_is_seen_by_the_clock_then_by_the_flag() {
        let start = Instant::now();
        let d = Deadline::new(Some(start), start);
        assert_eq!(d.expired(), Ok(()));
        assert_eq!(d.check(), Err(Error::DeadlineExceeded { limit_ms: 0 }));
        assert!(d.expired().is_err());
        let far = Deadline::new(Some(start + Duration::from_secs(3600)), start);
        assert_eq!(far.check(), Ok(()));
        let cancel = Cancel::new();
        let cancellable = Deadline::none().or_cancel(Some(&cancel));
        assert_eq!(cancellable.expired(), Ok(()));
        cancel.cancel();
        assert_eq!(cancellable.expired(), Err(Error::Cancelled));
        assert_eq!(cancellable.check(), Err(Error::Cancelled));
        assert_eq!(Deadline::none().check(), Ok(()));
        assert!(Error::DeadlineExceeded { limit_ms: 40 }
            .to_string()
            .contains("40 ms"));
    }
}
