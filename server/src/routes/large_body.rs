//! Bodies too large for axum's 2 MiB default (scene uploads, binary vertex
//! edits): read under a byte limit and counted against the server's upload
//! buffer, so concurrent requests never hold more than the budget in all.

use axum::body::{Body, Bytes};
use axum::http::{header, HeaderMap, StatusCode};
use http_body_util::{BodyExt, LengthLimitError, Limited};
use tokio::sync::OwnedSemaphorePermit;

use crate::app::AppState;
use crate::error::ApiError;

/// A body read whole, with its claim on the upload buffer (released when
/// dropped, once the body's work is done).
pub struct LargeBody {
    pub bytes: Bytes,
    _buffer: OwnedSemaphorePermit,
}

/// Reads `body`, at most `limit` bytes, after claiming room for it in the
/// upload buffer: its declared length, or `limit` without one. A declared
/// length over `limit` is refused before anything is read.
pub async fn read(
    state: &AppState,
    headers: &HeaderMap,
    body: Body,
    limit: usize,
) -> Result<LargeBody, ApiError> {
    let too_large = || ApiError::BadBody {
        status: StatusCode::PAYLOAD_TOO_LARGE,
        detail: format!(
            "the body exceeds this route's limit of {} MiB",
            limit.div_ceil(1 << 20)
        ),
    };
    let declared = headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok()?.parse::<usize>().ok());
    if declared.is_some_and(|n| n > limit) {
        return Err(too_large());
    }
    let kib = declared.unwrap_or(limit).div_ceil(1024).max(1);
    let budget = state.limits().max_buffered_upload_mib;
    let buffer = u32::try_from(kib)
        .ok()
        .and_then(|kib| {
            state
                .upload_buffer()
                .clone()
                .try_acquire_many_owned(kib)
                .ok()
        })
        .ok_or_else(|| {
            ApiError::UploadsBusy(format!(
                "uploads in flight fill this server's {budget} MiB upload buffer; retry shortly"
            ))
        })?;
    let bytes = match Limited::new(body, limit).collect().await {
        Ok(collected) => collected.to_bytes(),
        Err(e) if e.downcast_ref::<LengthLimitError>().is_some() => return Err(too_large()),
        Err(e) => {
            return Err(ApiError::BadBody {
                status: StatusCode::BAD_REQUEST,
                detail: format!("cannot read the body: {e}"),
            })
        }
    };
    Ok(LargeBody {
        bytes,
        _buffer: buffer,
    })
}

/// The request's media type without parameters, lower-case; `default`
/// when it has none.
pub fn media_type(headers: &HeaderMap, default: &str) -> String {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or(default)
        .split(';')
        .next()
        .unwrap_or_default()
        .trim()
        .to_ascii_lowercase()
}
