//! Everything a call can fail with: the server unreachable, an error
//! answer (with its RFC 9457 problem document when it has one), a stream
//! error frame, or an answer that is not what the route promises.

use frusta_api::Problem;

use crate::http::Answer;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{0}: expected an http:// or https:// URL")]
    Url(String),
    #[error("cannot reach {url}: {message}")]
    Transport { url: String, message: String },
    /// An answer with an error status; `title: detail` when it is a
    /// problem document, else the status and the start of the body (a
    /// proxy's page, say).
    #[error("{}", describe(.0))]
    Status(Box<Answer>),
    /// A stream's error frame: the update was refused, the stream is open.
    #[error("{0}")]
    Frame(Problem),
    #[error("the server's answer is not what the route sends: {0}")]
    Decode(#[from] serde_json::Error),
    #[error("stream: {0}")]
    Stream(Box<tungstenite::Error>),
    #[error("stream: {0}")]
    Protocol(String),
}

impl From<tungstenite::Error> for Error {
    fn from(e: tungstenite::Error) -> Self {
        Self::Stream(Box::new(e))
    }
}

impl Error {
    /// The problem document of an error answer or an error frame.
    pub fn problem(&self) -> Option<Problem> {
        match self {
            Self::Status(answer) => answer.problem(),
            Self::Frame(problem) => Some(problem.clone()),
            _ => None,
        }
    }
}

fn describe(answer: &Answer) -> String {
    match answer.problem() {
        Some(problem) => problem.to_string(),
        None => {
            let text = String::from_utf8_lossy(&answer.body);
            let excerpt: String = text.trim().chars().take(200).collect();
            format!("the server answered {}: {excerpt}", answer.status)
        }
    }
}
