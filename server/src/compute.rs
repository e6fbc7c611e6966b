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

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn a_full_queue_answers_busy_and_a_panic_is_an_internal_error() {
        let pool = ComputePool::new(1);
        let (release, wait) = std::sync::mpsc::channel::<()>();
        let blocked = pool.clone();
        let first = tokio::spawn(async move { blocked.run(move || wait.recv().is_ok()).await });
        // Until the first job ends, its permit is taken.
        while pool.permits.available_permits() > 0 {
            tokio::task::yield_now().await;
        }
        let refused = pool.run(|| ()).await;
        assert!(
            matches!(refused, Err(ApiError::Busy { queued: 1 })),
            "{refused:?}"
        );
        release.send(()).expect("release");
        assert!(first.await.expect("join").expect("ran"));
        let panicked = pool.run(|| panic!("boom")).await;
        assert!(
            matches!(&panicked, Err(ApiError::Internal(m)) if m.contains("boom")),
            "{panicked:?}"
        );
        assert_eq!(
            pool.run(|| 7).await.expect("ran"),
            7,
            "the pool survives a panic"
        );
    }
}
