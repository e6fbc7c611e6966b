//! `/v1/scenes`: uploads, the scene list and one scene's detail.

use std::borrow::Cow;

use frusta_engine::query::{ObjectStats, SceneBvhStats};
use serde::{Deserialize, Serialize};
use utoipa::openapi::schema::{AdditionalProperties, ArrayBuilder, ObjectBuilder, Type};
use utoipa::openapi::{RefOr, Schema};
use utoipa::{IntoParams, PartialSchema, ToSchema};

use crate::schemas::{Quaternion, Vector3};

#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
pub struct ObjectSummary {
    pub index: usize,
    pub name: String,
    pub triangles: usize,
    pub vertices: usize,
    pub dynamic: bool,
    /// Quaternion `[x, y, z, w]`.
    #[schema(value_type = Quaternion)]
    pub rotation: [f32; 4],
    #[schema(value_type = Vector3)]
    pub translation: [f32; 3],
}

/// A scene as the list shows it, and the answer to an upload.
#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
pub struct SceneSummary {
    pub id: String,
    /// Changes since the upload (one per new transform, new vertices or
    /// material edit), counted on across restarts, so a later state never
    /// has an earlier state's revision. Answers name the revision they
    /// were computed on.
    pub revision: u64,
    pub bundled: bool,
    pub created_unix_ms: u64,
    pub triangles: usize,
    pub objects: Vec<ObjectSummary>,
    /// Material names in id order, so a hit's material maps here.
    pub materials: Vec<String>,
    /// Time to build the acoustic hierarchy when the scene was loaded.
    pub build_ms: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
pub struct SceneList {
    pub scenes: Vec<SceneSummary>,
}

#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
pub struct SceneDetail {
    #[serde(flatten)]
    pub summary: SceneSummary,
    /// Per-object hierarchy statistics.
    pub bvh: BvhStats,
}

/// The hierarchies of a scene's objects.
#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
pub struct BvhStats {
    pub objects: Vec<ObjectBvhStats>,
    pub triangles: usize,
    pub memory_bytes: usize,
}

/// One object's hierarchy.
#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
pub struct ObjectBvhStats {
    pub triangles: usize,
    pub nodes: usize,
    pub depth: usize,
    /// Surface-area-heuristic cost of the traced tree.
    pub sah_cost: f32,
    pub memory_bytes: usize,
}

impl From<&SceneBvhStats> for BvhStats {
    fn from(stats: &SceneBvhStats) -> Self {
        let object = |o: &ObjectStats| ObjectBvhStats {
            triangles: o.triangles,
            nodes: o.nodes,
            depth: o.depth,
            sah_cost: o.sah_cost,
            memory_bytes: o.memory_bytes,
        };
        Self {
            objects: stats.objects.iter().map(object).collect(),
            triangles: stats.triangles,
            memory_bytes: stats.memory_bytes,
        }
    }
}

/// The query of `POST /v1/scenes`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct CreateQuery {
    /// The new scene's id (letters, digits, `-`, `_`; at most 64). Without
    /// it the id is made from the scene's name.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
    /// Object name for OBJ and glTF uploads (default `mesh`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub object: Option<String>,
    /// Material of every triangle of an OBJ or glTF upload whose file
    /// material is not a library material (default `concrete`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
}

/// A scene document (`scenes/README.md` is its reference). The schema
/// gives its shape; names, indices and material references are checked
/// when it loads, by the engine's own reader.
pub struct SceneUpload;

impl PartialSchema for SceneUpload {
    fn schema() -> RefOr<Schema> {
        let text = |description: &str| {
            ObjectBuilder::new()
                .schema_type(Type::String)
                .description(Some(description))
        };
        let object = ObjectBuilder::new()
            .property("name", text("Unique in the scene, not empty"))
            .property("material", text("Default material of its triangles"))
            .property(
                "dynamic",
                ObjectBuilder::new()
                    .schema_type(Type::Boolean)
                    .description(Some("Moves or deforms, so edits may change it")),
            )
            .property(
                "transform",
                ObjectBuilder::new()
                    .property("translation", Vector3::schema())
                    .property("rotation", Quaternion::schema())
                    .additional_properties(Some(AdditionalProperties::FreeForm(false))),
            )
            .property(
                "mesh",
                ObjectBuilder::new().description(Some(
                    "Inline `{vertices, triangles}`, or a generator: `box_room`, `l_room`, `two_rooms`, `hall`",
                )),
            )
            .required("name")
            .required("mesh")
            .additional_properties(Some(AdditionalProperties::FreeForm(false)));
        ObjectBuilder::new()
            .property("name", text("Display name"))
            .property("description", text("Free text"))
            .property(
                "materials",
                ObjectBuilder::new()
                    .description(Some("Materials by name, as in the materials PATCH"))
                    .additional_properties(Some(ObjectBuilder::new())),
            )
            .property(
                "objects",
                ArrayBuilder::new().items(object).min_items(Some(1)),
            )
            .required("objects")
            .additional_properties(Some(AdditionalProperties::FreeForm(false)))
            .into()
    }
}

impl ToSchema for SceneUpload {
    fn name() -> Cow<'static, str> {
        Cow::Borrowed("SceneDocument")
    }
}
