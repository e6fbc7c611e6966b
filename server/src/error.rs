//! One error type for every handler, rendered as an RFC 9457 problem
//! document (`application/problem+json`) so that clients parse a single
//! error shape whatever went wrong, including axum's own extractor
//! rejections.

use axum::extract::rejection::JsonRejection;
use axum::extract::FromRequest;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use serde::Serialize;

/// Everything a request can fail with.
#[derive(Debug, thiserror::Error)]
pub enum ApiError {
    #[error("no scene with id `{0}`")]
    SceneNotFound(String),
    #[error("no route for {0}")]
    RouteNotFound(String),
    /// The body was not the JSON the route expects; `status` and message
    /// come from axum's rejection (400 syntax, 415 content type, 413 size,
    /// 422 shape).
    #[error("{detail}")]
    BadBody { status: StatusCode, detail: String },
    #[error("{count} rays in one request; at most {max} are allowed")]
    TooManyRays { count: usize, max: usize },
    #[error("ray {index}: {reason}")]
    InvalidRay { index: usize, reason: &'static str },
    #[error("internal error: {0}")]
    Internal(String),
}

impl ApiError {
    fn status(&self) -> StatusCode {
        match self {
            Self::SceneNotFound(_) | Self::RouteNotFound(_) => StatusCode::NOT_FOUND,
            Self::BadBody { status, .. } => *status,
            Self::TooManyRays { .. } => StatusCode::PAYLOAD_TOO_LARGE,
            Self::InvalidRay { .. } => StatusCode::UNPROCESSABLE_ENTITY,
            Self::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// Stable machine-readable problem type; a URN because the service
    /// has no documentation site to dereference.
    fn kind(&self) -> &'static str {
        match self {
            Self::SceneNotFound(_) => "urn:frusta:problem:unknown-scene",
            Self::RouteNotFound(_) => "urn:frusta:problem:unknown-route",
            Self::BadBody { .. } => "urn:frusta:problem:bad-body",
            Self::TooManyRays { .. } => "urn:frusta:problem:too-many-rays",
            Self::InvalidRay { .. } => "urn:frusta:problem:invalid-ray",
            Self::Internal(_) => "urn:frusta:problem:internal",
        }
    }

    fn title(&self) -> &'static str {
        match self {
            Self::SceneNotFound(_) => "Unknown scene",
            Self::RouteNotFound(_) => "Unknown route",
            Self::BadBody { .. } => "Malformed request body",
            Self::TooManyRays { .. } => "Too many rays",
            Self::InvalidRay { .. } => "Invalid ray",
            Self::Internal(_) => "Internal error",
        }
    }
}

/// The RFC 9457 body; `ray_index` is an extension member so clients can
/// point at the offending ray without parsing `detail`.
#[derive(Serialize)]
struct Problem {
    #[serde(rename = "type")]
    kind: &'static str,
    title: &'static str,
    status: u16,
    detail: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    ray_index: Option<usize>,
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let status = self.status();
        if status.is_server_error() {
            tracing::error!(error = %self, "request failed");
        }
        let problem = Problem {
            kind: self.kind(),
            title: self.title(),
            status: status.as_u16(),
            detail: self.to_string(),
            ray_index: match self {
                Self::InvalidRay { index, .. } => Some(index),
                _ => None,
            },
        };
        // Serialising a struct of strings and integers cannot fail.
        let body = serde_json::to_vec(&problem).unwrap_or_default();
        (
            status,
            [(header::CONTENT_TYPE, "application/problem+json")],
            body,
        )
            .into_response()
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

/// `axum::Json` whose rejection is an [`ApiError`], so malformed bodies
/// come out as problem documents rather than axum's plain text.
#[derive(FromRequest)]
#[from_request(via(axum::Json), rejection(ApiError))]
pub struct JsonBody<T>(pub T);
