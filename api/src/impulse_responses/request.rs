//! The impulse-response request: sources, listeners and the engine's
//! `SimulationOptions`, whose schema is written out here with every
//! option's default and range (utoipa cannot derive it from the engine's
//! type), kept in step with the engine's option names by a test.

use std::borrow::Cow;

use frusta_engine::acoustics::diffraction::MAX_DIFFRACTION_ORDER;
use frusta_engine::acoustics::propagation::MAX_ORDER;
use frusta_engine::acoustics::signal::impulse_response::MAX_SAMPLE_RATE;
use frusta_engine::acoustics::signal::AirConditions;
use frusta_engine::acoustics::tail::{MAX_LENGTH_S, MAX_RAYS};
use frusta_engine::acoustics::MAX_SOURCE_REUSE_M;
use frusta_engine::acoustics::{CellAssignment, SimulationOptions, TailOptions};
use frusta_engine::scene::OCTAVE_BANDS_HZ;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use utoipa::openapi::schema::{
    AdditionalProperties, ArrayBuilder, ObjectBuilder, OneOfBuilder, Type,
};
use utoipa::openapi::{Ref, RefOr, Schema};
use utoipa::{PartialSchema, ToSchema};

use crate::schemas::Vector3;

/// A source or listener.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Point {
    /// `[x, y, z]` in metres.
    #[schema(value_type = Vector3)]
    pub position: [f32; 3],
}

impl From<Vec3> for Point {
    fn from(position: Vec3) -> Self {
        Self {
            position: position.to_array(),
        }
    }
}

fn is_exact(lod_error_m: &f32) -> bool {
    *lod_error_m == 0.0
}

impl ImpulseResponseRequest {
    /// One source and one listener.
    pub fn pair(source: Vec3, listener: Vec3, options: SimulationOptions) -> Self {
        Self {
            sources: vec![source.into()],
            listeners: vec![listener.into()],
            lod_error_m: 0.0,
            options,
        }
    }
}

/// The body of `POST /v1/scenes/{id}/impulse-responses` (and a stream's
/// `options`, without the points): sources, listeners and the engine's
/// `SimulationOptions`, each with its default and range. A test keeps the
/// option names in step with the engine's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImpulseResponseRequest {
    pub sources: Vec<Point>,
    pub listeners: Vec<Point>,
    /// Levels of detail: the scene simplified so that every corner lies
    /// within this many metres of the geometry traced (0: exact; not sent,
    /// so servers without levels of detail take the request).
    #[serde(default, skip_serializing_if = "is_exact")]
    pub lod_error_m: f32,
    #[serde(flatten)]
    pub options: SimulationOptions,
}

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
                ObjectBuilder::new()
                    .schema_type(utoipa::openapi::schema::SchemaType::from_iter([
                        Type::Integer,
                        Type::Null,
                    ]))
                    .description(Some(format!(
                        "Sub-frusta per frustum side, N (the server may cap it lower); null or omitted: {} with conservative cells, {} with sampled cells",
                        CellAssignment::Conservative.default_sampling(),
                        CellAssignment::Sampled.default_sampling()
                    )))
                    .minimum(Some(1))
                    .maximum(Some(64))
                    .into(),
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
            ("tail", tail_schema()),
            (
                "diffraction_order",
                integer(
                    "Most edges a diffracted path bends around (0: none; 2 costs far more in detailed scenes)",
                    defaults.diffraction_order,
                    0,
                    MAX_DIFFRACTION_ORDER,
                ),
            ),
            (
                "source_reuse_m",
                number(
                    "Streams: how far a source may move from where its frusta were traced before they are traced again, m (within it they are re-mirrored and every path validated exactly, but a path that opens after the move is missed until then; the tail's walk is renewed an eighth of its rays per update; 0 traces and walks at every move)",
                    defaults.source_reuse_m,
                    0.0,
                    MAX_SOURCE_REUSE_M,
                ),
            ),
        ]
    }
}

/// `"none"`, `null`, or the stochastic tail's options.
fn tail_schema() -> RefOr<Schema> {
    let defaults = TailOptions::default();
    let options = ObjectBuilder::new()
        .schema_type(Type::Object)
        .description(Some(
            "Late reverberation by stochastic ray tracing after the exact paths; omitted fields keep their defaults",
        ))
        .property(
            "rays",
            ObjectBuilder::new()
                .schema_type(Type::Integer)
                .description(Some("Rays traced from each source (the server may cap it lower)"))
                .default(Some(defaults.rays.into()))
                .minimum(Some(1))
                .maximum(Some(MAX_RAYS)),
        )
        .property(
            "max_length_s",
            ObjectBuilder::new()
                .schema_type(Type::Number)
                .description(Some(
                    "The tail ends here, s, or where every ray is 60 dB down",
                ))
                .default(Some(defaults.max_length_s.into()))
                .exclusive_minimum(Some(0.0))
                .maximum(Some(MAX_LENGTH_S)),
        )
        .property(
            "seed",
            ObjectBuilder::new()
                .schema_type(Type::Integer)
                .description(Some("Seed of the rays and of the tail's fine structure"))
                .default(Some(defaults.seed.into()))
                .minimum(Some(0)),
        )
        .property(
            "receiver_radius_m",
            ObjectBuilder::new()
                .schema_type(utoipa::openapi::schema::SchemaType::from_iter([
                    Type::Number,
                    Type::Null,
                ]))
                .description(Some(
                    "Radius of the sphere around each listener that counts rays, m, fixed; null sizes the smallest from the room and grows it with the path's length up to half a mean free path, counting only what the listener sees",
                ))
                .exclusive_minimum(Some(0.0)),
        )
        .additional_properties(Some(AdditionalProperties::FreeForm(false)));
    let none = ObjectBuilder::new()
        .schema_type(Type::String)
        .enum_values(Some(["none"]));
    let null = ObjectBuilder::new().schema_type(Type::Null);
    OneOfBuilder::new()
        .description(Some(
            "The late reverberation: \"none\" (or null) for the exact paths alone, or the options of the stochastic tail (default: on, all defaults)",
        ))
        .item(none)
        .item(null)
        .item(options)
        .into()
}

impl PartialSchema for ImpulseResponseRequest {
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
            .property(
                "lod_error_m",
                ObjectBuilder::new()
                    .schema_type(Type::Number)
                    .description(Some(
                        "Levels of detail: each object is simplified, every part of its tree whose surface lies within this many metres of a plane becoming one polygon, and the request is answered on that (0: exact geometry). Features smaller than the bound cost no frusta; answers report the bound in stats.lod_error_m (0 where it replaced nothing) and name the original triangle each polygon stands for. A scene's simplification at a bound is kept for the next request (up to a few per server) and moved with its objects",
                    ))
                    .default(Some(0.0.into()))
                    .minimum(Some(0.0)),
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

impl ToSchema for ImpulseResponseRequest {
    fn name() -> Cow<'static, str> {
        Cow::Borrowed("ImpulseResponseRequest")
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
        documented.retain(|name| !["sources", "listeners", "lod_error_m"].contains(name));
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
    fn a_request_is_the_options_beside_the_points() {
        let request = ImpulseResponseRequest::pair(Vec3::ONE, Vec3::X, Default::default());
        let json = serde_json::to_value(&request).expect("request");
        assert_eq!(
            json["sources"][0]["position"],
            serde_json::json!([1.0, 1.0, 1.0])
        );
        assert_eq!(json["max_order"], SimulationOptions::default().max_order);
        let back: ImpulseResponseRequest = serde_json::from_value(json).expect("read back");
        assert_eq!(back, request);
    }
}
