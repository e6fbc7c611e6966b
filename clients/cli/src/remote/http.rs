//! Requests to the server over blocking HTTP, every answer checked: a
//! transport failure names the server, an error status becomes its problem
//! document.

use std::error::Error;
use std::time::Duration;

use serde_json::Value;
use ureq::http::Response;
use ureq::typestate::{WithBody, WithoutBody};
use ureq::{Body, RequestBuilder};

use super::{problem, Server};

/// No overall timeout: a simulation may rightly take as long as the
/// server's own request limit, which the server enforces.
pub fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        // Error statuses carry problem documents, which `answer` reads.
        .http_status_as_error(false)
        .timeout_connect(Some(Duration::from_secs(10)))
        .build()
        .into()
}

impl Server {
    fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    fn authorized<B>(&self, request: RequestBuilder<B>) -> RequestBuilder<B> {
        match self.bearer() {
            Some(value) => request.header("authorization", value),
            None => request,
        }
    }

    pub(super) fn get(&self, path: &str) -> RequestBuilder<WithoutBody> {
        self.authorized(self.agent.get(self.url(path)))
    }

    pub(super) fn post(&self, path: &str) -> RequestBuilder<WithBody> {
        self.authorized(self.agent.post(self.url(path)))
    }

    pub(super) fn delete(&self, path: &str) -> RequestBuilder<WithoutBody> {
        self.authorized(self.agent.delete(self.url(path)))
    }

    /// POSTs `body` as JSON, asking for `accept`; the answer's bytes.
    pub(super) fn post_json(
        &self,
        path: &str,
        body: &Value,
        accept: &str,
    ) -> Result<Vec<u8>, Box<dyn Error>> {
        let sent = self
            .post(path)
            .header("content-type", "application/json")
            .header("accept", accept)
            .send(serde_json::to_vec(body)?);
        self.answer(sent)
    }

    /// The body of a successful answer. Unlimited in size: what is read
    /// (scene lists, impulse responses, WAV) grows only with what the
    /// user asked for.
    pub(super) fn answer(
        &self,
        sent: Result<Response<Body>, ureq::Error>,
    ) -> Result<Vec<u8>, Box<dyn Error>> {
        let mut response = sent.map_err(|e| format!("cannot reach {}: {e}", self.base))?;
        let bytes = response.body_mut().with_config().read_to_vec()?;
        let status = response.status();
        if status.is_success() {
            Ok(bytes)
        } else {
            Err(problem::from_answer(status.as_u16(), &bytes))
        }
    }
}
