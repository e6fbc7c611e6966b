//! CPU-bound work (building hierarchies, simulations, ray batches) runs on
//! rayon's pool, never on the async executor; the number of jobs waiting
//! for it is capped so overload answers 503 instead of growing a queue.

use std::sync::Arc;

use tokio::sync::{oneshot, Semaphore};

use crate::error::ApiError;

#[derive(Clone)]
pub struct ComputePool {
    permits: Arc<Semaphore>,
    capacity: usize,
}

impl ComputePool {
    pub fn new(capacity: usize) -> Self {
        Self {
            permits: Arc::new(Semaphore::new(capacity.max(1))),
            capacity: capacity.max(1),
        }
    }

    /// Runs `job` on rayon and awaits it. A panic in the job is an internal
    /// error for this request only.
    pub async fn run<T: Send + 'static>(
        &self,
        job: impl FnOnce() -> T + Send + 'static,
    ) -> Result<T, ApiError> {
        let permit = self
            .permits
            .clone()
            .try_acquire_owned()
            .map_err(|_| ApiError::Busy {
                queued: self.capacity,
            })?;
        let (tx, rx) = oneshot::channel();
        rayon::spawn(move || {
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(job));
            drop(permit);
            let _ = tx.send(result);
        });
        match rx.await {
            Ok(Ok(value)) => Ok(value),
            Ok(Err(panic)) => {
                let message = panic
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_owned())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                Err(ApiError::Internal(format!(
                    "computation panicked: {message}"
                )))
            }
            Err(_) => Err(ApiError::Internal("computation was dropped".into())),
        }
    }
}
