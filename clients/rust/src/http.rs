//! The HTTP side: one blocking agent per [`Client`] (keep-alive, so a
//! client that reads its answers to the end reuses its connection), every
//! status returned as an [`Answer`], which typed calls turn into a value
//! or an [`Error`].

use std::time::Duration;

use frusta_api::Problem;
use serde::de::DeserializeOwned;
use serde::Serialize;
use ureq::http::Request;
use ureq::AsSendBody;

use crate::Error;

/// How a [`Client`] talks to its server.
#[derive(Clone, Debug, Default)]
pub struct Config {
    /// Sent as `Authorization: Bearer KEY`, for servers with keys.
    pub api_key: Option<String>,
    /// The longest a whole exchange (and a stream read) may take. None by
    /// default: a simulation may rightly take as long as the server's own
    /// request limit, which the server enforces.
    pub timeout: Option<Duration>,
}

/// A server at `http://host:port` (or `https://` with the `tls` feature).
pub struct Client {
    /// With no trailing `/`, so paths append as they are.
    base: String,
    config: Config,
    agent: ureq::Agent,
}

/// One HTTP answer, whatever its status, read to the end.
#[derive(Clone, Debug)]
pub struct Answer {
    pub status: u16,
    pub content_type: String,
    /// Seconds to wait before coming back (503 under load).
    pub retry_after: Option<String>,
    pub body: Vec<u8>,
}

impl Answer {
    pub fn is_success(&self) -> bool {
        (200..300).contains(&self.status)
    }

    /// The body's problem document, if it is one.
    pub fn problem(&self) -> Option<Problem> {
        serde_json::from_slice(&self.body).ok()
    }

    /// Itself if successful, else the error it stands for.
    pub fn ok(self) -> Result<Self, Error> {
        if self.is_success() {
            Ok(self)
        } else {
            Err(Error::Status(Box::new(self)))
        }
    }

    /// A successful answer's body as `T`.
    pub fn json<T: DeserializeOwned>(self) -> Result<T, Error> {
        Ok(serde_json::from_slice(&self.ok()?.body)?)
    }
}

impl Client {
    pub fn new(url: &str, config: Config) -> Result<Self, Error> {
        if !(url.starts_with("http://") || url.starts_with("https://")) {
            return Err(Error::Url(url.to_owned()));
        }
        let agent = ureq::Agent::config_builder()
            // Error statuses carry problem documents, which `Answer` reads.
            .http_status_as_error(false)
            .timeout_connect(Some(Duration::from_secs(10)))
            .timeout_global(config.timeout)
            .build()
            .into();
        Ok(Self {
            base: url.trim_end_matches('/').to_owned(),
            config,
            agent,
        })
    }

    /// `http://host:port`, without a trailing `/`.
    pub fn base(&self) -> &str {
        &self.base
    }

    pub(crate) fn config(&self) -> &Config {
        &self.config
    }

    /// The `Authorization` header value, if a key was given.
    pub(crate) fn bearer(&self) -> Option<String> {
        self.config.api_key.as_ref().map(|k| format!("Bearer {k}"))
    }

    pub fn get(&self, path: &str) -> Result<Answer, Error> {
        self.send("GET", path, &[], ())
    }

    pub fn delete(&self, path: &str) -> Result<Answer, Error> {
        self.send("DELETE", path, &[], ())
    }

    pub fn post(&self, path: &str, content_type: &str, body: &[u8]) -> Result<Answer, Error> {
        self.send("POST", path, &[("content-type", content_type)], body)
    }

    pub fn patch(&self, path: &str, content_type: &str, body: &[u8]) -> Result<Answer, Error> {
        self.send("PATCH", path, &[("content-type", content_type)], body)
    }

    /// POSTs `body` as JSON.
    pub fn post_json(&self, path: &str, body: &impl Serialize) -> Result<Answer, Error> {
        self.post(path, "application/json", &serde_json::to_vec(body)?)
    }

    /// Sends one request and reads its answer to the end. Unlimited in
    /// size: what is read (scene lists, impulse responses, WAV) grows only
    /// with what the caller asked for.
    pub(crate) fn send(
        &self,
        method: &str,
        path: &str,
        headers: &[(&str, &str)],
        body: impl AsSendBody,
    ) -> Result<Answer, Error> {
        let transport = |message: String| Error::Transport {
            url: self.base.clone(),
            message,
        };
        let mut request = Request::builder()
            .method(method)
            .uri(format!("{}{path}", self.base));
        for (name, value) in headers {
            request = request.header(*name, *value);
        }
        if let Some(bearer) = self.bearer() {
            request = request.header("authorization", bearer);
        }
        let request = request.body(body).map_err(|e| transport(e.to_string()))?;
        let mut response = self
            .agent
            .run(request)
            .map_err(|e| transport(e.to_string()))?;
        let header = |name: &str| {
            let value = response.headers().get(name)?.to_str().ok();
            value.map(str::to_owned)
        };
        let (content_type, retry_after) = (header("content-type"), header("retry-after"));
        let body = response
            .body_mut()
            .with_config()
            .read_to_vec()
            .map_err(|e| transport(e.to_string()))?;
        Ok(Answer {
            status: response.status().as_u16(),
            content_type: content_type.unwrap_or_default(),
            retry_after,
            body,
        })
    }
}

/// `text` as one URL path segment or query value: letters, digits, `-`,
/// `_` and `~` stay, the rest (`.` too, so `..` cannot climb) is
/// percent-encoded, so an id cannot reach another route.
pub(crate) fn encode(text: &str) -> String {
    text.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'_' | b'~' => {
                char::from(b).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_stay_one_segment() {
        assert_eq!(encode("hall-10k_a"), "hall-10k_a");
        assert_eq!(encode("../x y"), "%2E%2E%2Fx%20y");
    }

    #[test]
    fn only_http_urls_are_servers() {
        let client = Client::new("http://h:1/", Config::default()).expect("client");
        assert_eq!(client.base(), "http://h:1");
        assert!(Client::new("h:1", Config::default()).is_err());
    }
}
