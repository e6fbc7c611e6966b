//! A compute deadline shared by the workers of one simulation.
//!
//! Reading the clock costs tens of nanoseconds, a frustum some
//! microseconds: workers read it every [`CLOCK_PERIOD`] frusta. The first to
//! see it passed raises a flag that every other worker reads on each
//! frustum (one relaxed load of a line nobody writes until then), so all
//! stop within one frustum of each other.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use crate::{Error, Result};

/// Frusta traced between two readings of the clock by one worker.
pub(crate) const CLOCK_PERIOD: u64 = 64;

pub(crate) struct Deadline {
    at: Option<Instant>,
    /// The limit as the caller granted it, for the error message.
    limit_ms: u64,
    expired: AtomicBool,
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

    /// Only reads the flag some worker raised: an error once one saw the
    /// deadline pass.
    #[inline]
    pub fn expired(&self) -> Result<()> {
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
        assert_eq!(Deadline::none().check(), Ok(()));
        assert!(Error::DeadlineExceeded { limit_ms: 40 }
            .to_string()
            .contains("40 ms"));
    }
}
