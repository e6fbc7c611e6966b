//! The server's errors: RFC 9457 problem documents, over HTTP
//! (`application/problem+json`) and on streams (`{"type": "error", ...}`).

use std::fmt;

use serde::Deserialize;

#[derive(Debug, Deserialize)]
pub struct Problem {
    pub title: String,
    pub detail: String,
}

impl fmt::Display for Problem {
    /// `title: detail`, which `main` prints after `error: `.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.title, self.detail)
    }
}

impl std::error::Error for Problem {}

/// The error an unsuccessful answer stands for: its problem document if it
/// is one, else the status and the start of the body (a proxy's page, say).
pub fn from_answer(status: u16, body: &[u8]) -> Box<dyn std::error::Error> {
    match serde_json::from_slice::<Problem>(body) {
        Ok(problem) => Box::new(problem),
        Err(_) => {
            let text = String::from_utf8_lossy(body);
            let excerpt: String = text.trim().chars().take(200).collect();
            format!("the server answered {status}: {excerpt}").into()
        }
    }
}
