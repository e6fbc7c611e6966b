//! `frusta-client`: what every Rust client of `frusta-server` (the CLI,
//! the benchmark, the integration tests) talks to it with. One blocking
//! HTTP agent ([`Client`]) whose answers parse into the `frusta-api` wire
//! types, error statuses into their problem documents ([`Error`]), and one
//! WebSocket reader and writer with typed frames ([`Stream`]).

mod collisions;
mod error;
mod http;
mod impulse_responses;
mod scenes;
mod shadows;
mod stream;

pub use error::Error;
pub use frusta_api as api;
pub use http::{Answer, Client, Config};
pub use stream::{Received, Stream};
