//! `POST /v1/scenes/{id}/shadows` and `.../visibility`: hard shadows of a
//! point light seen through a camera, and which points see it.

use frusta_api::shadows::{ShadowRequest, ShadowResponse, VisibilityRequest, VisibilityResponse};

use crate::http::encode;
use crate::{Client, Error};

impl Client {
    /// The visibility image as JSON (grey levels and stats).
    pub fn shadows(&self, id: &str, request: &ShadowRequest) -> Result<ShadowResponse, Error> {
        let path = format!("/v1/scenes/{}/shadows", encode(id));
        self.post_json(&path, request)?.json()
    }

    /// Which of the request's points see its light.
    pub fn visibility(
        &self,
        id: &str,
        request: &VisibilityRequest,
    ) -> Result<VisibilityResponse, Error> {
        let path = format!("/v1/scenes/{}/visibility", encode(id));
        self.post_json(&path, request)?.json()
    }
}
