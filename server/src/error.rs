//! One error type for every handler, rendered as an RFC 9457 problem
//! document (`application/problem+json`) so that clients parse a single
//! error shape whatever went wrong, including axum's own extractor
//! rejections.

use axum::extract::rejection::JsonRejection;
use axum::extract::{FromRequest, Request};
use axum::http::{header, HeaderValue, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use crate::config::Limits;
pub use frusta_api::Problem;

/// Everything a request can fail with.
#[derive(Debug, thiserror::Error)]
pub enum ApiError {
    #[error("no scene with id `{0}`")]
    SceneNotFound(String),
    #[error("a scene with id `{0}` exists already; delete it first or choose another id")]
    SceneExists(String),
    #[error("this same upload of `{0}` is still being stored; retry in a moment and it is answered with the stored scene")]
    UploadInFlight(String),
    #[error("no object {0}")]
    UnknownObject(String),
    #[error("no route for {0}")]
    RouteNotFound(String),
    /// The body was not the JSON the route expects; `status` and message
    /// come from axum's rejection (400 syntax, 415 content type, 413 size,
    /// 422 shape).
    #[error("{detail}")]
    BadBody { status: StatusCode, detail: String },
    /// A stream route reached without a valid WebSocket upgrade.
    #[error("this route speaks WebSocket: {detail}")]
    BadUpgrade { status: StatusCode, detail: String },
    #[error("{count} rays in one request; at most {max} are allowed")]
    TooManyRays { count: usize, max: usize },
    #[error("ray {index}: {reason}")]
    InvalidRay { index: usize, reason: &'static str },
    /// Well-formed input the engine cannot use: the message names the field.
    #[error("{0}")]
    Invalid(String),
    /// A request above one of the server's configured limits.
    #[error("{0}")]
    LimitExceeded(String),
    #[error("the simulation needed more than the {limit_ms} ms compute limit; lower max_order or sampling, or use \"cells\": \"sampled\"")]
    ComputeLimit { limit_ms: u64 },
    #[error("{0}")]
    ServerFull(String),
    #[error("{0}")]
    NotAcceptable(String),
    #[error("{0}")]
    UnsupportedMediaType(String),
    #[error("missing or unknown API key: send `Authorization: Bearer KEY`")]
    Unauthorized,
    #[error("{0}")]
    Forbidden(String),
    #[error("the server is busy with {queued} simulations; retry shortly")]
    Busy { queued: usize },
    #[error("{0}")]
    UploadsBusy(String),
    #[error("the request took longer than {seconds} s")]
    Timeout { seconds: u64 },
    #[error("internal error: {0}")]
    Internal(String),
    /// A response axum or a layer made without a problem document (405,
    /// path and query rejections), turned into one by [`problem_documents`].
    #[error("{detail}")]
    Http { status: StatusCode, detail: String },
}

impl ApiError {
    /// [`from_engine`](Self::from_engine) for work under the server's
    /// compute limit: the error names the limit, not what was left of it
    /// when this part of the work began.
    pub fn from_engine_within(e: frusta_engine::Error, limits: &Limits) -> Self {
        match Self::from_engine(e) {
            Self::ComputeLimit { .. } => Self::ComputeLimit {
                limit_ms: limits.max_compute_ms,
            },
            other => other,
        }
    }

    /// Maps an engine error by its cause: input to 4xx naming the field,
    /// limits to 422, the deadline to the compute limit, anything else to
    /// 500 with a logged error id.
    pub fn from_engine(e: frusta_engine::Error) -> Self {
        use frusta_engine::{Cause, Error};
        match (e.cause(), e) {
            (_, Error::UnknownObject(o)) => Self::UnknownObject(o),
            (_, Error::DeadlineExceeded { limit_ms }) => Self::ComputeLimit { limit_ms },
            (Cause::Input, e) => Self::Invalid(e.to_string()),
            (Cause::Limit, e) => Self::LimitExceeded(e.to_string()),
            // Cancelled work has no client left to read the answer. The
            // server reads no files on a client's behalf (uploads may not
            // reference files) and writes audio only to memory, so
            // environment errors are its own failures, not the input's.
            (Cause::Cancelled | Cause::Deadline | Cause::Environment, e) => {
                Self::Internal(e.to_string())
            }
        }
    }

    pub fn storage(e: crate::store::StoreError) -> Self {
        Self::Internal(format!("storage: {e}"))
    }

    fn status(&self) -> StatusCode {
        match self {
            Self::SceneNotFound(_) | Self::RouteNotFound(_) | Self::UnknownObject(_) => {
                StatusCode::NOT_FOUND
            }
            Self::SceneExists(_) | Self::UploadInFlight(_) => StatusCode::CONFLICT,
            Self::BadBody { status, .. }
            | Self::BadUpgrade { status, .. }
            | Self::Http { status, .. } => *status,
            Self::TooManyRays { .. } => StatusCode::PAYLOAD_TOO_LARGE,
            Self::InvalidRay { .. }
            | Self::Invalid(_)
            | Self::LimitExceeded(_)
            | Self::ComputeLimit { .. } => StatusCode::UNPROCESSABLE_ENTITY,
            Self::ServerFull(_) => StatusCode::INSUFFICIENT_STORAGE,
            Self::NotAcceptable(_) => StatusCode::NOT_ACCEPTABLE,
            Self::UnsupportedMediaType(_) => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            Self::Unauthorized => StatusCode::UNAUTHORIZED,
            Self::Forbidden(_) => StatusCode::FORBIDDEN,
            Self::Busy { .. } | Self::UploadsBusy(_) => StatusCode::SERVICE_UNAVAILABLE,
            Self::Timeout { .. } => StatusCode::GATEWAY_TIMEOUT,
            Self::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// Stable machine-readable problem type and its title; a URN because
    /// the service has no documentation site to dereference.
    fn kind(&self) -> (&'static str, &'static str) {
        match self {
            Self::SceneNotFound(_) => ("unknown-scene", "Unknown scene"),
            Self::SceneExists(_) => ("scene-exists", "Scene exists"),
            Self::UploadInFlight(_) => ("upload-in-flight", "Upload in flight"),
            Self::UnknownObject(_) => ("unknown-object", "Unknown object"),
            Self::RouteNotFound(_) => ("unknown-route", "Unknown route"),
            Self::BadBody { .. } => ("bad-body", "Malformed request body"),
            Self::BadUpgrade { .. } => ("bad-upgrade", "Not a WebSocket upgrade"),
            Self::TooManyRays { .. } => ("too-many-rays", "Too many rays"),
            Self::InvalidRay { .. } => ("invalid-ray", "Invalid ray"),
            Self::Invalid(_) => ("invalid-input", "Invalid input"),
            Self::LimitExceeded(_) => ("limit-exceeded", "Limit exceeded"),
            Self::ComputeLimit { .. } => ("compute-limit", "Compute limit exceeded"),
            Self::ServerFull(_) => ("server-full", "Server full"),
            Self::NotAcceptable(_) => ("not-acceptable", "Not acceptable"),
            Self::UnsupportedMediaType(_) => ("unsupported-media-type", "Unsupported media type"),
            Self::Unauthorized => ("unauthorized", "Unauthorized"),
            Self::Forbidden(_) => ("forbidden", "Forbidden"),
            Self::Busy { .. } => ("busy", "Server busy"),
            Self::UploadsBusy(_) => ("uploads-busy", "Too many uploads in flight"),
            Self::Timeout { .. } => ("timeout", "Request timed out"),
            Self::Internal(_) => ("internal", "Internal error"),
            Self::Http { status, .. } => match *status {
                StatusCode::METHOD_NOT_ALLOWED => ("method-not-allowed", "Method not allowed"),
                StatusCode::BAD_REQUEST => ("bad-request", "Bad request"),
                _ => (
                    "http-error",
                    status.canonical_reason().unwrap_or("HTTP error"),
                ),
            },
        }
    }

    /// The RFC 9457 document, also sent over WebSocket streams. A 500
    /// (ours, or one a layer made) is logged here with a fresh id that the
    /// document carries too, so what a client reports can be found in the log.
    pub fn problem(&self) -> Problem {
        let (kind, title) = self.kind();
        let unexpected = self.status() == StatusCode::INTERNAL_SERVER_ERROR;
        let error_id = unexpected.then(|| {
            let id = new_error_id();
            tracing::error!(error_id = %id, error = %self, "internal error");
            id
        });
        Problem {
            kind: format!("urn:frusta:problem:{kind}"),
            title: title.into(),
            status: self.status().as_u16(),
            detail: self.to_string(),
            ray_index: match self {
                Self::InvalidRay { index, .. } => Some(*index),
                _ => None,
            },
            error_id,
        }
    }
}

/// Unique in one server's log: its start time and a counter.
fn new_error_id() -> String {
    static START: std::sync::OnceLock<u128> = std::sync::OnceLock::new();
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    let start = START.get_or_init(|| {
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_millis())
    });
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    format!("{start:x}-{n}")
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let status = self.status();
        // 500s are logged with their id by `problem`.
        let expected = matches!(self, Self::Busy { .. } | Self::UploadsBusy(_))
            || status == StatusCode::INTERNAL_SERVER_ERROR;
        if status.is_server_error() && !expected {
            tracing::error!(error = %self, "request failed");
        }
        // Serialising a struct of strings and integers cannot fail.
        let body = serde_json::to_vec(&self.problem()).unwrap_or_default();
        let mut response = (
            status,
            [(header::CONTENT_TYPE, "application/problem+json")],
            body,
        )
            .into_response();
        let headers = response.headers_mut();
        match self {
            Self::Unauthorized => {
                headers.insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
            }
            Self::Busy { .. } | Self::UploadsBusy(_) | Self::UploadInFlight(_) => {
                headers.insert(header::RETRY_AFTER, HeaderValue::from_static("1"));
            }
            _ => {}
        }
        response
    }
}

impl From<JsonRejection> for ApiError {
    fn from(rejection: JsonRejection) -> Self {
        Self::BadBody {
            status: rejection.status(),
            detail: rejection.body_text(),
        }
    }
}

/// Makes every error response a problem document: those axum writes
/// itself (405 with an empty body, text/plain rejections of a path that is
/// not UTF-8 or a repeated query parameter) keep their status and headers
/// (`Allow`) and get the problem body, with axum's text as the detail.
pub async fn problem_documents(request: Request, next: Next) -> Response {
    let response = next.run(request).await;
    let status = response.status();
    let is_problem = response
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"application/problem+json"));
    if !(status.is_client_error() || status.is_server_error()) || is_problem {
        return response;
    }
    let (parts, body) = response.into_parts();
    // Rejection texts are a line; anything longer is cut, not buffered.
    let text = axum::body::to_bytes(body, 4096).await.unwrap_or_default();
    let detail = match String::from_utf8_lossy(&text).trim() {
        "" => status.canonical_reason().unwrap_or("error").to_owned(),
        text => text.to_owned(),
    };
    let mut problem = ApiError::Http { status, detail }.into_response();
    for (name, value) in &parts.headers {
        if name != header::CONTENT_TYPE && name != header::CONTENT_LENGTH {
            problem.headers_mut().append(name.clone(), value.clone());
        }
    }
    problem
}

/// `axum::Json` whose rejection is an [`ApiError`], so malformed bodies
/// come out as problem documents rather than axum's plain text. The body
/// must be a JSON object: serde reads a struct whose fields all have
/// defaults from an array too, and `[]` is no request.
pub struct JsonBody<T>(pub T);

impl<T: serde::de::DeserializeOwned, S: Send + Sync> FromRequest<S> for JsonBody<T> {
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, ApiError> {
        let (parts, body) = req.into_parts();
        let bytes =
            axum::body::Bytes::from_request(Request::from_parts(parts.clone(), body), state)
                .await
                .map_err(|e| ApiError::Http {
                    status: e.status(),
                    detail: e.body_text(),
                })?;
        let first = bytes.iter().find(|b| !b.is_ascii_whitespace());
        if first.is_some_and(|&b| b != b'{') {
            return Err(ApiError::Invalid("the body must be a JSON object".into()));
        }
        let request = Request::from_parts(parts, axum::body::Body::from(bytes));
        let axum::Json(value) = axum::Json::<T>::from_request(request, state).await?;
        Ok(Self(value))
    }
}

#[cfg(test)]
mod tests {
    use axum::body::Body;
    use axum::http::{Request, StatusCode};

    use super::ApiError;
    use crate::routes::test_support::*;

    #[tokio::test]
    async fn a_body_that_is_not_an_object_is_refused() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        // All of a collision request's fields have defaults: serde alone
        // would read `[]` as one.
        for body in ["[]", " [1]", "3", "\"x\"", "null"] {
            let (status, _, problem) = server
                .send(post_json("/v1/scenes/box/collisions", body))
                .await;
            assert_eq!(
                status,
                StatusCode::UNPROCESSABLE_ENTITY,
                "{body}: {problem}"
            );
        }
        let (status, _, _) = server
            .send(post_json("/v1/scenes/box/collisions", " {}"))
            .await;
        assert_eq!(status, StatusCode::OK);
    }

    /// Engine errors map by their cause: input names the field in a 4xx,
    /// limits are 422, and a failure of the server's own environment (an
    /// in-memory WAV write, say) is a 500 with a logged error id.
    #[tokio::test]
    async fn engine_errors_map_by_cause() {
        use frusta_engine::Error;
        let cases = [
            (
                Error::InvalidOption {
                    field: "sampling".into(),
                    reason: "0 must lie in 1..=64".into(),
                },
                StatusCode::UNPROCESSABLE_ENTITY,
                "sampling",
            ),
            (
                Error::LimitExceeded("hall would generate 9e9 triangles".into()),
                StatusCode::UNPROCESSABLE_ENTITY,
                "9e9",
            ),
            (
                Error::UnknownObject("door".into()),
                StatusCode::NOT_FOUND,
                "door",
            ),
            (
                Error::Audio {
                    path: "<memory>".into(),
                    reason: "forced".into(),
                },
                StatusCode::INTERNAL_SERVER_ERROR,
                "forced",
            ),
        ];
        for (error, status, named) in cases {
            let internal = status == StatusCode::INTERNAL_SERVER_ERROR;
            let problem = ApiError::from_engine(error).problem();
            assert_eq!(problem.status, status.as_u16(), "{problem}");
            assert!(problem.detail.contains(named), "{problem}");
            assert_eq!(problem.error_id.is_some(), internal, "{problem}");
        }
        let limit = ApiError::from_engine(Error::LimitExceeded("x".into())).problem();
        assert!(limit.kind.ends_with("limit-exceeded"), "{}", limit.kind);
    }

    #[tokio::test]
    async fn errors_axum_writes_itself_are_problem_documents() {
        let server = TestServer::new();
        let cases = [
            // Method not allowed: axum answers with an empty body.
            (Request::put("/v1/scenes"), StatusCode::METHOD_NOT_ALLOWED),
            (Request::delete("/healthz"), StatusCode::METHOD_NOT_ALLOWED),
            // A path segment that is not UTF-8.
            (Request::get("/v1/scenes/%FF%FE"), StatusCode::BAD_REQUEST),
            // A repeated query parameter.
            (
                Request::post("/v1/scenes?id=a&id=b"),
                StatusCode::BAD_REQUEST,
            ),
        ];
        for (builder, expected) in cases {
            let request = builder
                .header("content-type", "application/json")
                .body(Body::from(BOX_DOC))
                .unwrap();
            let uri = request.uri().clone();
            let (status, content_type, problem) = server.send(request).await;
            assert_eq!(status, expected, "{uri}: {problem}");
            assert_eq!(content_type, "application/problem+json", "{uri}");
            assert_eq!(problem["status"], expected.as_u16(), "{uri}");
            assert!(!problem["detail"].as_str().unwrap().is_empty(), "{uri}");
        }
        let response = tower::ServiceExt::oneshot(
            crate::router(server.state.clone()),
            Request::put("/v1/scenes").body(Body::empty()).unwrap(),
        )
        .await
        .unwrap();
        let allow = response
            .headers()
            .get("allow")
            .map(|v| v.to_str().unwrap().to_owned());
        assert!(allow.is_some_and(|a| a.contains("POST")));
    }
}
