//! `/v1/scenes`: the list, one scene, uploads, deletes and object edits.

use std::io::Read;

use frusta_api::objects::{EditReport, ObjectPatch};
use frusta_api::scenes::{CreateQuery, SceneDetail, SceneList, SceneSummary};
use ureq::SendBody;

use crate::http::encode;
use crate::{Client, Error};

impl Client {
    pub fn scenes(&self) -> Result<SceneList, Error> {
        self.get("/v1/scenes")?.json()
    }

    pub fn scene(&self, id: &str) -> Result<SceneDetail, Error> {
        self.get(&format!("/v1/scenes/{}", encode(id)))?.json()
    }

    /// Uploads `len` bytes of `content_type` (a scene document, OBJ or
    /// glTF) read from `body`. The length is sent, so the body goes
    /// length-delimited rather than chunked, which every proxy accepts.
    pub fn upload(
        &self,
        query: &CreateQuery,
        content_type: &str,
        len: u64,
        mut body: impl Read,
    ) -> Result<SceneSummary, Error> {
        let pairs = [
            ("id", &query.id),
            ("object", &query.object),
            ("material", &query.material),
        ];
        let query: Vec<String> = pairs
            .iter()
            .filter_map(|(name, value)| Some(format!("{name}={}", encode(value.as_deref()?))))
            .collect();
        let path = match query.is_empty() {
            true => "/v1/scenes".to_owned(),
            false => format!("/v1/scenes?{}", query.join("&")),
        };
        let len = len.to_string();
        let headers = [("content-type", content_type), ("content-length", &len)];
        self.send("POST", &path, &headers, SendBody::from_reader(&mut body))?
            .json()
    }

    pub fn delete_scene(&self, id: &str) -> Result<(), Error> {
        self.delete(&format!("/v1/scenes/{}", encode(id)))?.ok()?;
        Ok(())
    }

    /// Moves or deforms `object` (a name or an index).
    pub fn edit_object(
        &self,
        id: &str,
        object: &str,
        patch: &ObjectPatch,
    ) -> Result<EditReport, Error> {
        let path = format!("/v1/scenes/{}/objects/{}", encode(id), encode(object));
        let body = serde_json::to_vec(patch)?;
        self.patch(&path, "application/json", &body)?.json()
    }
}
