//! `POST /v1/scenes/{id}/collisions`: discrete, proximity and continuous
//! collision queries, with optional moves applied in the same step.

use frusta_api::collisions::{CollisionRequest, CollisionResponse};

use crate::http::encode;
use crate::{Client, Error};

impl Client {
    pub fn collisions(
        &self,
        id: &str,
        request: &CollisionRequest,
    ) -> Result<CollisionResponse, Error> {
        let path = format!("/v1/scenes/{}/collisions", encode(id));
        self.post_json(&path, request)?.json()
    }
}
