//! `frusta` as a client of `frusta-server` (through `frusta-client`):
//! which server to talk to, and the commands that run there.

pub mod ir;
pub mod scenes;
pub mod stream;

use std::error::Error;

use frusta_client::{Client, Config};

/// The server named by `--server` (or `FRUSTA_SERVER`), with the key that
/// `--api-key` (or `FRUSTA_API_KEY`) gives.
pub fn client(url: Option<&str>, api_key: Option<&str>) -> Result<Client, Box<dyn Error>> {
    let url = url.ok_or("this command runs on a server: give --server URL or set FRUSTA_SERVER")?;
    let config = Config {
        api_key: api_key.map(str::to_owned),
        ..Config::default()
    };
    Ok(Client::new(url, config).map_err(|e| format!("--server {e}"))?)
}
