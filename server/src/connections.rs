//! The accept loop: what `axum::serve` does, plus the two bounds it lacks.
//! A client must send a request's headers within the header timeout (hyper
//! enforces it once it has a timer, which `axum::serve` never gives it),
//! and at most `max_connections` are open at once; past that, new ones
//! wait in the listen backlog. Without both, 20,000 half-sent requests
//! used up the file descriptors and `/healthz` failed.

use std::pin::pin;
use std::sync::Arc;

use axum::Router;
use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio::sync::Semaphore;
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;

use crate::config::Limits;

/// Serves `app` on `listener` until `shutdown` is cancelled, then lets
/// every connection finish its request in flight and returns. Upgraded
/// connections (streams) leave the count when they upgrade: streams have
/// their own cap.
pub async fn accept(
    listener: TcpListener,
    app: Router,
    limits: &Limits,
    shutdown: &CancellationToken,
) {
    let open = Arc::new(Semaphore::new(limits.max_connections.max(1)));
    let connections = TaskTracker::new();
    let header_timeout = limits.header_timeout();
    loop {
        let permit = tokio::select! {
            permit = open.clone().acquire_owned() => permit,
            () = shutdown.cancelled() => break,
        };
        let Ok(permit) = permit else { break };
        let stream = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                Err(e) => {
                    // Out of descriptors or a connection reset before
                    // accept: wait a moment instead of spinning.
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(std::time::Duration::from_millis(20)).await;
                    continue;
                }
            },
            () = shutdown.cancelled() => break,
        };
        let service = TowerToHyperService::new(app.clone());
        let shutdown = shutdown.clone();
        connections.spawn(async move {
            let _permit = permit;
            let mut builder = http1::Builder::new();
            builder
                .timer(TokioTimer::new())
                .header_read_timeout(header_timeout);
            let mut connection = pin!(builder
                .serve_connection(TokioIo::new(stream), service)
                .with_upgrades());
            let finished = tokio::select! {
                finished = connection.as_mut() => finished,
                () = shutdown.cancelled() => {
                    connection.as_mut().graceful_shutdown();
                    connection.await
                }
            };
            if let Err(e) = finished {
                tracing::debug!(error = %e, "connection closed with an error");
            }
        });
    }
    // New clients are refused at once while the open connections finish.
    drop(listener);
    connections.close();
    connections.wait().await;
}
