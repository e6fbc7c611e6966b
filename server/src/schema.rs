//! OpenAPI schemas for the fixed-size arrays of the wire format.
//!
//! utoipa renders `[f32; 3]` as an array of any length and any number;
//! these say what the server accepts (exactly three or four finite `f32`
//! values), so clients generated from `/openapi.json`, and schemathesis in
//! CI, send what the server takes.

use std::borrow::Cow;

use frusta_engine::acoustics::propagation::MAX_ORDER;
use frusta_engine::acoustics::signal::impulse_response::MAX_SAMPLE_RATE;
use frusta_engine::acoustics::signal::AirConditions;
use frusta_engine::acoustics::SimulationOptions;
use frusta_engine::scene::{BAND_COUNT, OCTAVE_BANDS_HZ};
use utoipa::openapi::schema::{
    AdditionalProperties, ArrayBuilder, KnownFormat, ObjectBuilder, OneOfBuilder, SchemaFormat,
    Type,
};
use utoipa::openapi::{Ref, RefOr, Schema};
use utoipa::PartialSchema;

/// `[x, y, z]`: a position or direction, metres.
pub struct Vector3;

/// `[x, y, z, w]`: a rotation quaternion.
pub struct Quaternion;

/// The smallest magnitude a JSON number read as `f32` rounds to infinity
/// from: `f32::MAX` plus half its last place. Below it a number rounds to a
/// finite `f32` and is taken; from it on it is refused as not finite.
const F32_OVERFLOW: f64 = f32::MAX as f64 + (1u128 << 103) as f64;

fn finite_f32_array(len: usize, description: &str) -> RefOr<Schema> {
    let component = ObjectBuilder::new()
        .schema_type(Type::Number)
        .format(Some(SchemaFormat::KnownFormat(KnownFormat::Float)))
        .exclusive_minimum(Some(-F32_OVERFLOW))
        .exclusive_maximum(Some(F32_OVERFLOW));
    ArrayBuilder::new()
        .items(component)
        .min_items(Some(len))
        .max_items(Some(len))
        .description(Some(description))
        .build()
        .into()
}

impl utoipa::PartialSchema for Vector3 {
    fn schema() -> RefOr<Schema> {
        finite_f32_array(3, "`[x, y, z]`, finite 32-bit floats")
    }
}

impl utoipa::ToSchema for Vector3 {
    fn name() -> Cow<'static, str> {
        Cow::Borrowed("Vector3")
    }
}

impl utoipa::PartialSchema for Quaternion {
    fn schema() -> RefOr<Schema> {
        finite_f32_array(
            4,
            "`[x, y, z, w]`, finite 32-bit floats, not all zero (normalised by the server)",
        )
    }
}

impl utoipa::ToSchema for Quaternion {
    fn name() -> Cow<'static, str> {
        Cow::Borrowed("Quaternion")
    }
}

/// The body of `POST /v1/scenes/{id}/impulse-responses` (and a stream's
/// `options`, without the points): sources, listeners and the engine's
/// `SimulationOptions`, each with its default and range. A test keeps the
/// option names in step with the engine's.
pub struct ImpulseResponseRequest;

impl ImpulseResponseRequest {
    /// The options' schemas, by name.
    fn options() -> Vec<(&'static str, RefOr<Schema>)> {
        let defaults = SimulationOptions::default();
        let air_defaults = AirConditions::default();
        let integer = |description: &str, default: u32, min: u32, max: u32| -> RefOr<Schema> {
            ObjectBuilder::new()
                .schema_type(Type::Integer)
                .description(Some(description))
                .default(Some(default.into()))
                .minimum(Some(min))
                .maximum(Some(max))
                .into()
        };
        let number = |description: &str, default: f64, min: f64, max: f64| -> RefOr<Schema> {
            ObjectBuilder::new()
                .schema_type(Type::Number)
                .description(Some(description))
                .default(Some(default.into()))
                .minimum(Some(min))
                .maximum(Some(max))
                .into()
        };
        let choice = |description: &str, values: &[&str]| -> RefOr<Schema> {
            ObjectBuilder::new()
                .schema_type(Type::String)
                .description(Some(description))
                .enum_values(Some(values.iter().copied()))
                .default(Some(values[0].into()))
                .into()
        };
        let bands = ArrayBuilder::new()
            .description(Some(
                "Octave band centres to compute, each once (default: all)",
            ))
            .items(
                ObjectBuilder::new()
                    .schema_type(Type::Number)
                    .enum_values(Some(OCTAVE_BANDS_HZ.iter().map(|&hz| f64::from(hz)))),
            )
            .min_items(Some(1))
            .unique_items(true);
        let air = ObjectBuilder::new()
            .schema_type(utoipa::openapi::schema::SchemaType::from_iter([
                Type::Object,
                Type::Null,
            ]))
            .description(Some(
                "Air absorption (ISO 9613-1); null turns it off. Omitted fields keep their defaults",
            ))
            .property(
                "temperature_c",
                number("Air temperature, °C", air_defaults.temperature_c, -60.0, 60.0),
            )
            .property(
                "relative_humidity_percent",
                number(
                    "Relative humidity, %",
                    air_defaults.relative_humidity_percent,
                    0.0,
                    100.0,
                ),
            )
            .property(
                "pressure_kpa",
                number(
                    "Atmospheric pressure, kPa",
                    air_defaults.pressure_kpa,
                    10.0,
                    200.0,
                ),
            )
            .additional_properties(Some(AdditionalProperties::FreeForm(false)));
        let listener_frame = ObjectBuilder::new()
            .description(Some(
                "The listener's head: where the nose and the top of the head point (not parallel)",
            ))
            .property("forward", Vector3::schema())
            .property("up", Vector3::schema())
            .required("forward")
            .required("up")
            .additional_properties(Some(AdditionalProperties::FreeForm(false)));
        vec![
            (
                "max_order",
                integer("Highest reflection order (the server may cap it lower)", defaults.max_order, 0, MAX_ORDER),
            ),
            (
                "sampling",
                integer("Sub-frusta per frustum side, N (the server may cap it lower)", defaults.sampling, 1, 64),
            ),
            (
                "primary_split",
                integer("Frusta per cube-face side leaving the source", defaults.primary_split, 1, 16),
            ),
            (
                "energy_threshold",
                ObjectBuilder::new()
                    .schema_type(Type::Number)
                    .description(Some(
                        "Energy, relative to the source, below which a frustum spawns no more",
                    ))
                    .default(Some(f64::from(defaults.energy_threshold).into()))
                    .minimum(Some(0.0))
                    .exclusive_maximum(Some(1.0))
                    .into(),
            ),
            (
                "cells",
                choice(
                    "How sub-frusta meet triangles: conservative finds every path, sampled bounds the work",
                    &["conservative", "sampled"],
                ),
            ),
            ("bands_hz", bands.into()),
            ("air", air.into()),
            (
                "sample_rate",
                integer("Hz", defaults.sample_rate, 1, MAX_SAMPLE_RATE),
            ),
            ("channels", choice("Mono, or binaural (left and right ears)", &["mono", "binaural"])),
            ("listener_frame", listener_frame.into()),
        ]
    }
}

impl utoipa::PartialSchema for ImpulseResponseRequest {
    fn schema() -> RefOr<Schema> {
        let points = |description: &str| {
            ArrayBuilder::new()
                .description(Some(description))
                .items(Ref::from_schema_name("Point"))
                .min_items(Some(1))
        };
        let mut body = ObjectBuilder::new()
            .description(Some(
                "Sources, listeners and simulation options; every option has a default",
            ))
            .property("sources", points("Sound sources"))
            .property(
                "listeners",
                points("Listeners; one response per source-listener pair"),
            )
            .required("sources")
            .required("listeners")
            .additional_properties(Some(AdditionalProperties::FreeForm(false)));
        for (name, schema) in Self::options() {
            body = body.property(name, schema);
        }
        body.into()
    }
}

impl utoipa::ToSchema for ImpulseResponseRequest {
    fn name() -> Cow<'static, str> {
        Cow::Borrowed("ImpulseResponseRequest")
    }
}

/// Raw bytes: an OBJ, a GLB or binary vertices.
pub struct Binary;

impl utoipa::PartialSchema for Binary {
    fn schema() -> RefOr<Schema> {
        ObjectBuilder::new()
            .schema_type(Type::String)
            .format(Some(SchemaFormat::KnownFormat(KnownFormat::Binary)))
            .into()
    }
}

impl utoipa::ToSchema for Binary {}

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

/// `{"materials": {name: material}}`: a library material's name, or
/// coefficients (transmission may not exceed absorption in any band).
pub struct MaterialsPatch;

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

impl utoipa::ToSchema for MaterialsPatch {}

/// A scene document (`scenes/README.md` is its reference). The schema
/// gives its shape; names, indices and material references are checked
/// when it loads.
pub struct SceneUpload;

impl utoipa::PartialSchema for SceneUpload {
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

impl utoipa::ToSchema for SceneUpload {
    fn name() -> Cow<'static, str> {
        Cow::Borrowed("SceneDocument")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn impulse_response_options_are_the_engines() {
        let RefOr::T(Schema::Object(body)) = ImpulseResponseRequest::schema() else {
            panic!("an object schema");
        };
        let mut documented: Vec<&str> = body.properties.keys().map(String::as_str).collect();
        documented.retain(|name| !["sources", "listeners"].contains(name));
        documented.sort_unstable();
        let options = serde_json::to_value(SimulationOptions::default()).expect("options");
        let mut taken: Vec<&str> = options
            .as_object()
            .expect("an object")
            .keys()
            .map(String::as_str)
            .collect();
        taken.sort_unstable();
        assert_eq!(documented, taken);
    }

    #[test]
    fn the_f32_bound_is_where_reading_overflows() {
        let read = |x: f64| serde_json::from_str::<f32>(&x.to_string()).unwrap();
        assert_eq!(read(F32_OVERFLOW.next_down()), f32::MAX);
        assert!(read(F32_OVERFLOW).is_infinite());
        assert!(read(-F32_OVERFLOW).is_infinite());
    }

    #[test]
    fn vectors_have_exactly_their_components() {
        let schema = serde_json::to_value(Vector3::schema()).expect("schema");
        assert_eq!(schema["minItems"], 3);
        assert_eq!(schema["maxItems"], 3);
        let schema = serde_json::to_value(Quaternion::schema()).expect("schema");
        assert_eq!(schema["minItems"], 4);
        assert_eq!(schema["maxItems"], 4);
    }
}
