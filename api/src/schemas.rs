//! OpenAPI schemas utoipa cannot derive: the fixed-size arrays of the wire
//! format, and binary bodies.
//!
//! utoipa renders `[f32; 3]` as an array of any length and any number;
//! these say what the server accepts (exactly three or four finite `f32`
//! values), so clients generated from `/openapi.json`, and schemathesis in
//! CI, send what the server takes.

use std::borrow::Cow;

use utoipa::openapi::schema::{ArrayBuilder, KnownFormat, ObjectBuilder, SchemaFormat, Type};
use utoipa::openapi::{RefOr, Schema};

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

/// `["a", "b"]`: two objects by name or index.
pub struct ObjectPair;

impl utoipa::PartialSchema for ObjectPair {
    fn schema() -> RefOr<Schema> {
        ArrayBuilder::new()
            .items(ObjectBuilder::new().schema_type(Type::String))
            .min_items(Some(2))
            .max_items(Some(2))
            .description(Some("Two objects, each by name or index"))
            .build()
            .into()
    }
}

impl utoipa::ToSchema for ObjectPair {
    fn name() -> Cow<'static, str> {
        Cow::Borrowed("ObjectPair")
    }
}

/// Raw bytes: an OBJ, a GLB, a WAV or binary vertices.
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

#[cfg(test)]
mod tests {
    use super::*;
    use utoipa::PartialSchema;

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
        let schema = serde_json::to_value(ObjectPair::schema()).expect("schema");
        assert_eq!(
            (&schema["minItems"], &schema["maxItems"]),
            (&2.into(), &2.into())
        );
    }
}
