//! CPU-bound work (building hierarchies, simulations, ray batches) runs on
//! rayon, never on the async executor; the number of jobs waiting for it
//! is capped so overload answers 503 instead of growing a queue.
//!
//! Jobs start in arrival order, no more at once than there are cores (four
//! at most), and each running job has a rayon pool of its own. A job's
//! parallel loops wait for their stolen parts, and a rayon thread that
//! waits runs whatever else is queued in its pool: with every request in
//! one pool, a late request ran inside an early one's wait and delayed it
//! (64 queued impulse responses answered with p50 27 ms and p99 20 s), and
//! a job waiting for a scene's lock inside the wait of the job holding it
//! would deadlock. A pool per running job makes both impossible; one job
//! at a time in one pool would too, but leaves a core idle in each job's
//! serial parts (121 against 182 impulse responses per second in
//! `frusta-bench serve`).

use std::sync::{Arc, Mutex};

use rayon::ThreadPool;
use tokio::sync::{oneshot, Semaphore};

use crate::error::ApiError;

/// Jobs running at once, at most (see [`ComputePool::new`]).
const MAX_RUNNING: usize = 4;

#[derive(Clone)]
pub struct ComputePool {
    /// Jobs waiting or running, at most `capacity`.
    permits: Arc<Semaphore>,
    capacity: usize,
    /// Jobs running, one per pool; waiters are served first come, first
    /// served.
    running: Arc<Semaphore>,
    /// Pools of the jobs not running, made on first need.
    idle: Arc<Mutex<Vec<Arc<ThreadPool>>>>,
    threads: usize,
}

impl ComputePool {
    /// A pool that holds up to `capacity` jobs and runs one per core at
    /// once, four at most, each with as many threads as there are cores.
    /// Two already keep every core busy through one job's serial parts;
    /// past four, more pools would only multiply threads on the same cores.
    pub fn new(capacity: usize) -> Self {
        let cores = rayon::current_num_threads();
        Self::with_workers(capacity, cores.min(MAX_RUNNING), cores)
    }

    fn with_workers(capacity: usize, workers: usize, threads: usize) -> Self {
        Self {
            permits: Arc::new(Semaphore::new(capacity.max(1))),
            capacity: capacity.max(1),
            running: Arc::new(Semaphore::new(workers.max(1))),
            idle: Arc::default(),
            threads: threads.max(1),
        }
    }

    /// Workers free to start a job now.
    #[cfg(test)]
    pub(crate) fn idle_workers(&self) -> usize {
        self.running.available_permits()
    }

    /// An idle pool, or a new one while fewer than `workers` exist.
    fn take_pool(&self) -> Result<Arc<ThreadPool>, ApiError> {
        if let Some(pool) = self.idle.lock().unwrap_or_else(|e| e.into_inner()).pop() {
            return Ok(pool);
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(self.threads)
            .thread_name(|i| format!("frusta-compute-{i}"))
            .build()
            .map(Arc::new)
            .map_err(|e| ApiError::Internal(format!("could not start compute threads: {e}")))
    }

    /// Runs `job` on a rayon pool of its own and awaits it. A panic in the job is an internal
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
        let running = self
            .running
            .clone()
            .acquire_owned()
            .await
            .map_err(|_| ApiError::Internal("the compute pool is closed".into()))?;
        let pool = self.take_pool()?;
        let (idle, own) = (self.idle.clone(), pool.clone());
        let (tx, rx) = oneshot::channel();
        pool.spawn(move || {
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(job));
            // The pool is idle again before its permit lets the next job in.
            idle.lock().unwrap_or_else(|e| e.into_inner()).push(own);
            drop((running, permit));
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

    #[tokio::test]
    async fn jobs_run_in_arrival_order_no_more_at_once_than_workers() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        use std::sync::Mutex;

        let pool = ComputePool::with_workers(16, 1, 2);
        let active = Arc::new(AtomicUsize::new(0));
        let most = Arc::new(AtomicUsize::new(0));
        let order = Arc::new(Mutex::new(Vec::new()));
        let job = |i: usize| {
            let (active, most, order) = (active.clone(), most.clone(), order.clone());
            move || {
                let now = active.fetch_add(1, Ordering::SeqCst) + 1;
                most.fetch_max(now, Ordering::SeqCst);
                order.lock().expect("lock").push(i);
                std::thread::sleep(std::time::Duration::from_millis(2));
                active.fetch_sub(1, Ordering::SeqCst);
            }
        };
        let (release, wait) = std::sync::mpsc::channel::<()>();
        let first = {
            let (pool, job) = (pool.clone(), job(0));
            tokio::spawn(async move {
                pool.run(move || {
                    wait.recv().expect("released");
                    job()
                })
                .await
            })
        };
        while pool.running.available_permits() > 0 {
            tokio::task::yield_now().await;
        }
        let mut later = Vec::new();
        for i in 1..=5 {
            let (queued, job) = (pool.clone(), job(i));
            later.push(tokio::spawn(async move { queued.run(job).await }));
            // Queued (waiting for the worker) before the next one arrives.
            while pool.permits.available_permits() > 16 - 1 - i {
                tokio::task::yield_now().await;
            }
        }
        release.send(()).expect("release");
        first.await.expect("join").expect("ran");
        for l in later {
            l.await.expect("join").expect("ran");
        }
        assert_eq!(*order.lock().expect("lock"), vec![0, 1, 2, 3, 4, 5]);
        assert_eq!(most.load(Ordering::SeqCst), 1);
    }

    /// A job that holds a lock through a parallel loop and a job waiting
    /// for that lock: in one shared pool the second can start inside the
    /// first one's wait, on the thread that holds the lock, and never end.
    #[tokio::test]
    async fn a_job_waiting_for_a_lock_never_runs_inside_the_holder() {
        use rayon::prelude::*;
        use std::time::Duration;

        let pool = ComputePool::new(16);
        let lock = Arc::new(Mutex::new(0u64));
        for _ in 0..20 {
            let (holder, waiter) = (lock.clone(), lock.clone());
            let (held, is_held) = std::sync::mpsc::channel::<()>();
            let first = {
                let pool = pool.clone();
                tokio::spawn(async move {
                    pool.run(move || {
                        let mut sum = holder.lock().expect("lock");
                        held.send(()).expect("signal");
                        *sum += (0..64u64)
                            .into_par_iter()
                            .map(|i| {
                                std::thread::sleep(Duration::from_micros(200));
                                i
                            })
                            .sum::<u64>();
                    })
                    .await
                })
            };
            let second = {
                let pool = pool.clone();
                tokio::spawn(async move {
                    pool.run(move || {
                        is_held.recv().expect("held");
                        *waiter.lock().expect("lock") += 1;
                    })
                    .await
                })
            };
            let both = async {
                first.await.expect("join").expect("ran");
                second.await.expect("join").expect("ran");
            };
            tokio::time::timeout(Duration::from_secs(20), both)
                .await
                .expect("deadlock: the waiter ran inside the holder");
        }
        assert_eq!(*lock.lock().expect("lock"), 20 * (2016 + 1));
    }
}
