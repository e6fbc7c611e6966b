//! `POST /v1/scenes/{id}/impulse-responses` as JSON: paths, parameters and
//! the samples' shape. The samples themselves come with a stream's answer
//! ([`crate::Stream`]).

use frusta_api::impulse_responses::{ImpulseResponseRequest, ImpulseResponses};

use crate::http::encode;
use crate::{Client, Error};

impl Client {
    pub fn impulse_responses(
        &self,
        id: &str,
        request: &ImpulseResponseRequest,
    ) -> Result<ImpulseResponses, Error> {
        let path = format!("/v1/scenes/{}/impulse-responses", encode(id));
        self.post_json(&path, request)?.json()
    }
}
