//! `PATCH /v1/scenes/{id}/materials`: materials changed or added by name.

use std::collections::BTreeMap;

use frusta_engine::scene::BAND_COUNT;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use utoipa::openapi::schema::{
    AdditionalProperties, ArrayBuilder, ObjectBuilder, OneOfBuilder, Type,
};
use utoipa::openapi::{RefOr, Schema};
use utoipa::ToSchema;

/// `{"materials": {name: material}}`: a library material's name, or
/// coefficients (transmission may not exceed absorption in any band). The
/// materials are the scene document's, read by the engine's own reader.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialsPatch {
    pub materials: BTreeMap<String, Value>,
}

#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
pub struct MaterialsEdited {
    pub revision: u64,
    /// Every material name in id order after the edit.
    pub materials: Vec<String>,
}

/// An energy coefficient in [0, 1]: one for all eight bands, or one per band.
fn coefficient(description: &str) -> RefOr<Schema> {
    let unit = || {
        ObjectBuilder::new()
            .schema_type(Type::Number)
            .minimum(Some(0.0))
            .maximum(Some(1.0))
    };
    OneOfBuilder::new()
        .description(Some(description))
        .item(unit())
        .item(
            ArrayBuilder::new()
                .items(unit())
                .min_items(Some(BAND_COUNT))
                .max_items(Some(BAND_COUNT)),
        )
        .into()
}

impl utoipa::PartialSchema for MaterialsPatch {
    fn schema() -> RefOr<Schema> {
        let custom = ObjectBuilder::new()
            .property(
                "absorption",
                coefficient("Fraction of incident energy not reflected"),
            )
            .property(
                "scattering",
                coefficient("Fraction of reflected energy reflected diffusely (default 0)"),
            )
            .property(
                "transmission",
                coefficient("Fraction passing through (default 0); at most `absorption`"),
            )
            .required("absorption")
            .additional_properties(Some(AdditionalProperties::FreeForm(false)));
        let material = OneOfBuilder::new()
            .item(
                ObjectBuilder::new()
                    .schema_type(Type::String)
                    .description(Some("A library material, e.g. `concrete`")),
            )
            .item(custom);
        ObjectBuilder::new()
            .property(
                "materials",
                ObjectBuilder::new()
                    .description(Some("New or changed materials by name"))
                    .additional_properties(Some(AdditionalProperties::RefOr(material.into()))),
            )
            .required("materials")
            .additional_properties(Some(AdditionalProperties::FreeForm(false)))
            .into()
    }
}

impl ToSchema for MaterialsPatch {}
