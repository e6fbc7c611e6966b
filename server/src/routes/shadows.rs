//! `POST /v1/scenes/{id}/shadows`: hard shadows of a point light or soft
//! shadows of an area light seen through a camera, by selective ray
//! tracing on the scene's hierarchy.

use axum::extract::{Path, State};
use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use axum::Json;
use frusta_api::schemas::Binary;
use frusta_api::shadows::{png, ShadowRequest, ShadowResponse};
use frusta_engine::shadows::Light;

use crate::app::AppState;
use crate::error::{ApiError, JsonBody, Problem};

/// Most pixels one request may ask for (1024 x 1024; a larger view is
/// asked for in tiles).
pub const MAX_PIXELS: u64 = 1024 * 1024;
/// Largest light-map face a request may ask for: six faces of 512^2
/// texels at 32 bytes hold 50 MiB, and two requests run at once.
pub const MAX_SHADOW_MAP_SIZE: u32 = 512;

/// Most light samples per side a request may ask for (8 x 8 per pixel or
/// point).
pub const MAX_SAMPLES: u32 = 8;
/// Most shadow rays full ray tracing of one area-light image may need
/// (receivers x samples^2): 1024^2 pixels at 16 samples, 512^2 at 64,
/// about a second of tracing on two cores.
pub const MAX_SAMPLE_RAYS: u64 = 1 << 24;

/// Body: `{"camera": {"position", "look_at", "width", "height", ...},
/// "light": {"position"[, "shape", ...]} or {"shape": "directional",
/// "direction"}, "method", "samples"}`. Send
/// `Accept: image/png` for a grey image (255 lit, 0 shadowed, the fraction
/// of an area light seen between), else JSON with the same levels and
/// stats.
#[utoipa::path(post, path = "/v1/scenes/{id}/shadows", tag = "queries",
    params(("id" = String, Path, description = "Scene id")),
    request_body = ShadowRequest,
    responses(
        (status = 200, description = "The visibility image as JSON, or with `Accept: image/png` as a greyscale PNG",
            content((ShadowResponse = "application/json"), (Binary = "image/png"))),
        (status = 404, body = Problem, content_type = "application/problem+json"),
        (status = 422, body = Problem, content_type = "application/problem+json"),
        (status = 503, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn render(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
    JsonBody(request): JsonBody<ShadowRequest>,
) -> Result<Response, ApiError> {
    let entry = state.registry().get(&id)?;
    let (camera, light, options) = request.engine().map_err(ApiError::Invalid)?;
    let pixels = camera.width as u64 * camera.height as u64;
    if pixels > MAX_PIXELS {
        return Err(ApiError::LimitExceeded(format!(
            "the image has {pixels} pixels; at most {MAX_PIXELS} are allowed"
        )));
    }
    if options.shadow_map_size > MAX_SHADOW_MAP_SIZE {
        return Err(ApiError::LimitExceeded(format!(
            "shadow_map_size {} exceeds {MAX_SHADOW_MAP_SIZE}",
            options.shadow_map_size
        )));
    }
    check_samples(&light, pixels, options.samples)?;
    camera.check().map_err(ApiError::from_engine)?;
    light.check().map_err(ApiError::from_engine)?;
    options.check().map_err(ApiError::from_engine)?;
    let as_png = headers
        .get(header::ACCEPT)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|a| a.contains("image/png"));
    let cache = state.clone();
    let (revision, image) = state
        .queries()
        .run(move || {
            let live = entry.read();
            let (world, revision) = (live.acoustic.bvh(), live.acoustic.revision());
            let shadows = cache.shadow_cache().get(&live.acoustic);
            (revision, shadows.shadows(world, &camera, &light, &options))
        })
        .await?;
    let image = image.map_err(ApiError::from_engine)?;
    if as_png {
        let bytes = png(&image).map_err(ApiError::Internal)?;
        return Ok(([(header::CONTENT_TYPE, "image/png")], bytes).into_response());
    }
    Ok(Json(ShadowResponse::new(revision, &image)).into_response())
}

/// A limit error past [`MAX_SAMPLES`] per side, or when `receivers` of an
/// area light would need more than [`MAX_SAMPLE_RAYS`] rays (the engine
/// refuses 0 samples).
pub fn check_samples(light: &Light, receivers: u64, samples: u32) -> Result<(), ApiError> {
    if samples > MAX_SAMPLES {
        return Err(ApiError::LimitExceeded(format!(
            "samples {samples} exceeds {MAX_SAMPLES} per side"
        )));
    }
    let rays = receivers * samples as u64 * samples as u64;
    if matches!(light, Light::Area(_)) && rays > MAX_SAMPLE_RAYS {
        return Err(ApiError::LimitExceeded(format!(
            "{receivers} receivers at {samples} x {samples} samples need {rays} rays; at most {MAX_SAMPLE_RAYS}"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use axum::http::StatusCode;
    use serde_json::json;

    fn body(width: u32) -> serde_json::Value {
        json!({
            "camera": {"position": [1, 1, 2.5], "look_at": [6, 4, 0], "width": width, "height": 24},
            "light": {"position": [5, 3, 2.8]},
        })
    }

    /// The answers of `request` on `scene` by the selective method (asked
    /// to succeed) and by full ray tracing.
    async fn selective_and_full(
        server: &TestServer,
        scene: &str,
        mut request: serde_json::Value,
    ) -> (serde_json::Value, serde_json::Value) {
        let uri = format!("/v1/scenes/{scene}/shadows");
        let (status, _, selective) = server.send(post_json(&uri, &request.to_string())).await;
        assert_eq!(status, StatusCode::OK, "{selective}");
        request["method"] = json!("full");
        let (_, _, full) = server.send(post_json(&uri, &request.to_string())).await;
        (selective, full)
    }

    #[tokio::test]
    async fn a_panel_casts_a_shadow_and_selective_equals_full() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let (selective, full) = selective_and_full(&server, "box", body(32)).await;
        assert_eq!(selective["visibility"], full["visibility"]);
        let levels = selective["visibility"].as_array().unwrap();
        assert_eq!(levels.len(), 32 * 24);
        assert!(levels.iter().all(|v| v == 0 || v == 255));
        assert!(selective["stats"]["receivers"].as_u64().unwrap() > 0);
    }

    #[tokio::test]
    async fn a_panel_light_casts_a_penumbra_and_selective_equals_full() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let mut soft = body(48);
        soft["light"] = json!({"position": [5, 3, 2.8], "shape": "rectangle", "u": [0.4, 0, 0], "v": [0, 0.3, 0]});
        soft["samples"] = json!(3);
        soft["seed"] = json!(5);
        let (selective, full) = selective_and_full(&server, "box", soft).await;
        assert_eq!(selective["visibility"], full["visibility"]);
        let levels: Vec<u8> = serde_json::from_value(full["visibility"].clone()).unwrap();
        assert!(levels.iter().any(|v| *v > 0 && *v < 255), "no penumbra");
        assert_eq!(
            full["stats"]["rays"],
            json!(full["stats"]["receivers"].as_u64().unwrap() * 9)
        );
    }

    #[tokio::test]
    async fn the_sun_and_a_spot_light_cast_shadows_and_selective_equals_full() {
        // Open to the sky: a floor and the panel over it.
        let yard = json!({
            "materials": {"walls": {"absorption": 0.1}},
            "objects": [
                {"name": "floor", "material": "walls",
                 "mesh": {"vertices": [[0, 0, 0], [10, 0, 0], [10, 6, 0], [0, 6, 0]],
                          "triangles": [[0, 1, 2], [0, 2, 3]]}},
                {"name": "panel", "material": "walls",
                 "mesh": {"vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, 2], [4, 1, 2]],
                          "triangles": [[0, 1, 2], [0, 2, 3]]}}
            ]
        });
        let server = TestServer::new();
        server
            .send(post_json("/v1/scenes?id=yard", &yard.to_string()))
            .await;
        let mut sun = body(32);
        sun["light"] = json!({"shape": "directional", "direction": [0.6, 0.2, -1]});
        let (selective, full) = selective_and_full(&server, "yard", sun).await;
        assert_eq!(selective["visibility"], full["visibility"]);
        let levels: Vec<u8> = serde_json::from_value(full["visibility"].clone()).unwrap();
        assert!(levels.contains(&0) && levels.contains(&255));
        // A spot light over the panel lights a disc of the floor.
        let mut spot = body(32);
        spot["light"] = json!({"shape": "spot", "position": [5, 3, 2.8],
                               "direction": [0, 0, -1], "half_angle_deg": 40});
        let (status, _, spot) = server
            .send(post_json("/v1/scenes/yard/shadows", &spot.to_string()))
            .await;
        assert_eq!(status, StatusCode::OK, "{spot}");
        let lit = |doc: &serde_json::Value| {
            let levels: Vec<u8> = serde_json::from_value(doc["visibility"].clone()).unwrap();
            levels.iter().filter(|v| **v == 255).count()
        };
        assert!(
            lit(&spot) > 0 && lit(&spot) < lit(&full),
            "{} {}",
            lit(&spot),
            lit(&full)
        );
    }

    #[tokio::test]
    async fn a_png_holds_the_same_levels() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let (_, _, json) = server
            .send(post_json("/v1/scenes/box/shadows", &body(32).to_string()))
            .await;
        let mut request = post_json("/v1/scenes/box/shadows", &body(32).to_string());
        request
            .headers_mut()
            .insert("accept", "image/png".parse().expect("header"));
        let (status, content_type, bytes) = server.send_raw(request).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(content_type, "image/png");
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
            .read_info()
            .expect("PNG");
        let mut pixels = vec![0; reader.output_buffer_size().expect("size")];
        let info = reader.next_frame(&mut pixels).expect("frame");
        assert_eq!((info.width, info.height), (32, 24));
        assert_eq!(info.color_type, png::ColorType::Grayscale);
        let levels: Vec<u8> = serde_json::from_value(json["visibility"].clone()).unwrap();
        assert_eq!(&pixels[..info.buffer_size()], &levels[..]);
        assert!(levels.contains(&0) && levels.contains(&255));
    }

    #[tokio::test]
    async fn bad_cameras_lights_and_sizes_are_refused() {
        let server = TestServer::new();
        let mut same = body(8);
        same["camera"]["look_at"] = json!([1, 1, 2.5]);
        let mut dark = body(8);
        dark["light"]["position"] = json!([0, 1e39, 0]);
        let mut huge = body(8);
        huge["camera"]["width"] = json!(5000);
        huge["camera"]["height"] = json!(5000);
        let mut map = body(8);
        map["shadow_map_size"] = json!(8);
        let mut unknown = body(8);
        unknown["lights"] = json!([]);
        let light = |l: serde_json::Value| {
            let mut doc = body(8);
            doc["light"] = l;
            doc
        };
        let half_rectangle =
            light(json!({"position": [5, 3, 2.8], "shape": "rectangle", "u": [1, 0, 0]}));
        let radius_of_a_point = light(json!({"position": [5, 3, 2.8], "radius": 1}));
        let flat_sphere = light(json!({"position": [5, 3, 2.8], "shape": "sphere", "radius": 0}));
        let edgeways_disk = light(
            json!({"position": [5, 3, 2.8], "shape": "disk", "normal": [0, 0, 0], "radius": 1}),
        );
        let sun_without_direction = light(json!({"shape": "directional"}));
        let sun_with_position =
            light(json!({"shape": "directional", "direction": [0, 0, -1], "position": [1, 1, 1]}));
        let sun_of_no_direction = light(json!({"shape": "directional", "direction": [0, 0, 0]}));
        let point_without_position = light(json!({}));
        let spot_without_cone =
            light(json!({"shape": "spot", "position": [5, 3, 2.8], "direction": [0, 0, -1]}));
        let spot_of_no_cone = light(
            json!({"shape": "spot", "position": [5, 3, 2.8], "direction": [0, 0, -1], "half_angle_deg": 0}),
        );
        let mut many_samples = body(8);
        many_samples["samples"] = json!(super::MAX_SAMPLES + 1);
        let mut no_samples = body(8);
        no_samples["samples"] = json!(0);
        // 1024^2 pixels at 8 x 8 samples: 67 M rays.
        let mut too_many_rays = body(1024);
        too_many_rays["camera"]["height"] = json!(1024);
        too_many_rays["light"] = json!({"position": [5, 3, 2.8], "shape": "sphere", "radius": 0.2});
        too_many_rays["samples"] = json!(8);
        for (doc, status) in [
            (same, StatusCode::UNPROCESSABLE_ENTITY),
            (dark, StatusCode::UNPROCESSABLE_ENTITY),
            (huge, StatusCode::UNPROCESSABLE_ENTITY),
            (map, StatusCode::UNPROCESSABLE_ENTITY),
            (unknown, StatusCode::UNPROCESSABLE_ENTITY),
            (half_rectangle, StatusCode::UNPROCESSABLE_ENTITY),
            (radius_of_a_point, StatusCode::UNPROCESSABLE_ENTITY),
            (flat_sphere, StatusCode::UNPROCESSABLE_ENTITY),
            (edgeways_disk, StatusCode::UNPROCESSABLE_ENTITY),
            (sun_without_direction, StatusCode::UNPROCESSABLE_ENTITY),
            (sun_with_position, StatusCode::UNPROCESSABLE_ENTITY),
            (sun_of_no_direction, StatusCode::UNPROCESSABLE_ENTITY),
            (point_without_position, StatusCode::UNPROCESSABLE_ENTITY),
            (spot_without_cone, StatusCode::UNPROCESSABLE_ENTITY),
            (spot_of_no_cone, StatusCode::UNPROCESSABLE_ENTITY),
            (many_samples, StatusCode::UNPROCESSABLE_ENTITY),
            (no_samples, StatusCode::UNPROCESSABLE_ENTITY),
            (too_many_rays, StatusCode::UNPROCESSABLE_ENTITY),
        ] {
            let (got, _, problem) = server
                .send(post_json("/v1/scenes/shoebox/shadows", &doc.to_string()))
                .await;
            assert_eq!(got, status, "{doc}");
            assert!(problem["type"].is_string(), "{doc}");
        }
        let (got, _, _) = server
            .send(post_json("/v1/scenes/none/shadows", &body(8).to_string()))
            .await;
        assert_eq!(got, StatusCode::NOT_FOUND);
    }
}
