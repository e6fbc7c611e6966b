//! The optional API keys: with keys configured, every `/v1` request names
//! one (`Authorization: Bearer KEY`), and a scene can be changed only with
//! the key that created it. Keys are kept and compared as SHA-256 digests,
//! so the store never holds a key itself.

use axum::extract::{Request, State};
use axum::http::header;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use sha2::{Digest, Sha256};

use crate::app::AppState;
use crate::error::ApiError;
use crate::store::SceneMeta;

/// Who is calling: the digest of their key, or `None` on an open server.
#[derive(Clone, Debug)]
pub struct Caller {
    pub key: Option<String>,
}

pub fn digest(key: &str) -> String {
    Sha256::digest(key.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

impl Caller {
    /// Whether this caller may edit or delete a scene.
    pub fn may_change(&self, meta: &SceneMeta) -> Result<(), ApiError> {
        match (&self.key, &meta.owner) {
            (None, _) => Ok(()),
            (Some(k), Some(owner)) if k == owner => Ok(()),
            (Some(_), None) => Err(ApiError::Forbidden(
                "bundled scenes are shared and read-only on a server with API keys; upload a copy to edit it".into(),
            )),
            (Some(_), Some(_)) => Err(ApiError::Forbidden(
                "this scene was created with another API key".into(),
            )),
        }
    }
}

/// Middleware over `/v1`: resolves the caller or answers 401.
pub async fn authenticate(
    State(state): State<AppState>,
    mut request: Request,
    next: Next,
) -> Response {
    let caller = if state.api_keys().is_empty() {
        Caller { key: None }
    } else {
        let presented = request
            .headers()
            .get(header::AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.strip_prefix("Bearer "))
            .map(|k| digest(k.trim()));
        match presented {
            Some(d) if state.api_keys().contains(&d) => Caller { key: Some(d) },
            _ => return ApiError::Unauthorized.into_response(),
        }
    };
    request.extensions_mut().insert(caller);
    next.run(request).await
}
