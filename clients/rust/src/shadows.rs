//! `POST /v1/scenes/{id}/shadows`: hard shadows of a point light seen
//! through a camera.

use frusta_api::shadows::{ShadowRequest, ShadowResponse};

use crate::http::encode;
use crate::{Client, Error};

impl Client {
    /// The visibility image as JSON (grey levels and stats).
    pub fn shadows(&self, id: &str, request: &ShadowRequest) -> Result<ShadowResponse, Error> {
        let path = format!("/v1/scenes/{}/shadows", encode(id));
        self.post_json(&path, request)?.json()
    }
}
