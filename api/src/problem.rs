//! RFC 9457 problem documents: the body of every error answer
//! (`application/problem+json`) and of every stream error frame.

use std::fmt;

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// The RFC 9457 body; `ray_index` and `error_id` are extension members so
/// clients can point at the offending ray without parsing `detail`, and
/// report an internal error by the id the server logged it under.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Problem {
    /// A stable URN, `urn:frusta:problem:<name>`.
    #[serde(rename = "type")]
    pub kind: String,
    pub title: String,
    pub status: u16,
    /// What to change.
    pub detail: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ray_index: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error_id: Option<String>,
}

impl fmt::Display for Problem {
    /// `title: detail`, what a person needs to read.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.title, self.detail)
    }
}

impl std::error::Error for Problem {}
