//! The server on a thread of its own with its own runtime: what tests,
//! benchmarks and embedders start when they need a real server on a
//! loopback port without a child process.

use std::net::SocketAddr;
use std::thread::JoinHandle;

use tokio::sync::oneshot;

use crate::Config;

/// A running server; dropping it shuts it down gracefully and waits.
pub struct BackgroundServer {
    pub addr: SocketAddr,
    stop: Option<oneshot::Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl BackgroundServer {
    /// Opens `config`'s data directory and serves on `config.addr` (port 0
    /// picks a free one); returns once it listens.
    pub fn start(config: Config) -> Result<Self, String> {
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let (stop, stopped) = oneshot::channel::<()>();
        let thread = std::thread::spawn(move || {
            let runtime = match tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
            {
                Ok(r) => r,
                Err(e) => {
                    let _ = ready_tx.send(Err(format!("cannot start a runtime: {e}")));
                    return;
                }
            };
            runtime.block_on(async move {
                let bound = tokio::net::TcpListener::bind(config.addr)
                    .await
                    .and_then(|l| l.local_addr().map(|a| (l, a)));
                let (listener, addr) = match bound {
                    Ok(b) => b,
                    Err(e) => {
                        let _ =
                            ready_tx.send(Err(format!("cannot listen on {}: {e}", config.addr)));
                        return;
                    }
                };
                let state = match crate::open(&config) {
                    Ok(s) => s,
                    Err(e) => {
                        let _ = ready_tx.send(Err(e));
                        return;
                    }
                };
                let _ = ready_tx.send(Ok(addr));
                let shutdown = async {
                    let _ = stopped.await;
                };
                if let Err(e) = crate::serve(state, listener, shutdown).await {
                    tracing::error!("server error: {e}");
                }
            });
        });
        let addr = ready_rx
            .recv()
            .map_err(|_| "the server thread ended before listening".to_owned())??;
        Ok(Self {
            addr,
            stop: Some(stop),
            thread: Some(thread),
        })
    }

    /// `http://ADDR`.
    pub fn url(&self) -> String {
        format!("http://{}", self.addr)
    }

    /// Shuts down gracefully: in-flight requests finish, streams close.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for BackgroundServer {
    fn drop(&mut self) {
        self.shutdown();
    }
}
