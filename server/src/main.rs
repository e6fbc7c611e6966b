//! `frusta-server`: loads the bundled scenes, builds their acceleration
//! structures, and answers ray queries over HTTP.

mod app;
mod catalog;
mod error;
mod routes;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use tracing_subscriber::EnvFilter;

#[derive(Parser)]
#[command(version, about = "Serve ray queries on frusta scenes over HTTP")]
struct Args {
    /// Address to listen on.
    #[arg(long, env = "FRUSTA_ADDR", default_value = "127.0.0.1:8080")]
    addr: SocketAddr,
    /// Directory whose `*.json` scenes are loaded at startup.
    #[arg(long, env = "FRUSTA_SCENES_DIR", default_value = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes"))]
    scenes_dir: PathBuf,
}

#[tokio::main]
async fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info")),
        )
        .init();
    let args = Args::parse();
    match run(args).await {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("{e}");
            ExitCode::FAILURE
        }
    }
}

async fn run(args: Args) -> Result<(), String> {
    let start = Instant::now();
    let dir = args.scenes_dir.clone();
    // Loading and BVH building are CPU-bound; keep them off the runtime.
    let catalog = tokio::task::spawn_blocking(move || catalog::load_dir(&dir))
        .await
        .map_err(|e| format!("loading scenes panicked: {e}"))?
        .map_err(|e| format!("cannot read {}: {e}", args.scenes_dir.display()))?;
    tracing::info!(
        scenes = catalog.len(),
        seconds = start.elapsed().as_secs_f64(),
        "scenes loaded"
    );
    let listener = tokio::net::TcpListener::bind(args.addr)
        .await
        .map_err(|e| format!("cannot listen on {}: {e}", args.addr))?;
    tracing::info!(addr = %args.addr, "listening");
    axum::serve(listener, app::router(app::AppState::new(catalog)))
        .with_graceful_shutdown(shutdown_signal())
        .await
        .map_err(|e| format!("server error: {e}"))?;
    tracing::info!("shut down");
    Ok(())
}

/// Resolves on Ctrl-C or SIGTERM (what container runtimes send), letting
/// in-flight requests finish.
async fn shutdown_signal() {
    let ctrl_c = async {
        if let Err(e) = tokio::signal::ctrl_c().await {
            tracing::error!("cannot listen for Ctrl-C: {e}");
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let terminate = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut signal) => {
                signal.recv().await;
            }
            Err(e) => {
                tracing::error!("cannot listen for SIGTERM: {e}");
                std::future::pending::<()>().await;
            }
        }
    };
    #[cfg(not(unix))]
    let terminate = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => {},
        () = terminate => {},
    }
    tracing::info!("shutdown signal received, finishing in-flight requests");
}
