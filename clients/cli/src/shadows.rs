//! `frusta shadows`: how much of a light reaches each pixel of a camera's
//! view, as a greyscale PNG (255 lit, 0 shadowed; between, the fraction of
//! an area light seen), computed here or (with `--scene-id`) on the
//! server, with the same image either way.

use std::error::Error;
use std::path::PathBuf;

use clap::ValueEnum;
use frusta_client::api::shadows::{
    png, png_of_levels, CameraSpec, LightShape, LightSpec, ShadowMethod, ShadowRequest,
};
use frusta_client::Client;
use frusta_engine::bvh::{BuildOptions, SceneBvh};
use frusta_engine::scene::Scene;
use frusta_engine::shadows::ShadowScene;
use glam::Vec3;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Method {
    /// Exact: selective where its light map pays, else full.
    Auto,
    /// Exact: rays only where the light map cannot prove a pixel.
    Selective,
    /// A ray per pixel.
    Full,
    /// The plain shadow map: fast, wrong near edges.
    ShadowMap,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Shape {
    Point,
    Spot,
    Directional,
    Rectangle,
    Disk,
    Sphere,
}

#[derive(clap::Args)]
pub struct ShadowArgs {
    /// Scene file (`.json`, `.obj`, `.gltf`, `.glb`), for an image made here.
    #[arg(
        long,
        conflicts_with = "scene_id",
        required_unless_present = "scene_id"
    )]
    scene: Option<PathBuf>,
    /// A scene on the server (needs `--server`).
    #[arg(long)]
    pub scene_id: Option<String>,
    /// Camera position `X,Y,Z`.
    #[arg(long, value_parser = crate::vec3::parse, allow_hyphen_values = true)]
    camera: Vec3,
    /// Point the camera looks at, `X,Y,Z`.
    #[arg(long, value_parser = crate::vec3::parse, allow_hyphen_values = true)]
    look_at: Vec3,
    /// Camera up, `X,Y,Z`.
    #[arg(long, value_parser = crate::vec3::parse, allow_hyphen_values = true, default_value = "0,0,1")]
    up: Vec3,
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 60.0)]
    fov: f32,
    #[arg(long, default_value_t = 640)]
    width: u32,
    #[arg(long, default_value_t = 480)]
    height: u32,
    /// Light position `X,Y,Z` (an area light's centre; a directional
    /// light has none).
    #[arg(long, value_parser = crate::vec3::parse, allow_hyphen_values = true)]
    light: Option<Vec3>,
    /// `point` (hard shadows), `spot` (a point shining into a cone: needs
    /// `--light-direction`, `--light-half-angle`), `directional` (the sun,
    /// hard shadows: needs `--light-direction`, no `--light`), or an area
    /// light: `rectangle` (needs
    /// `--light-u`, `--light-v`), `disk` (`--light-normal`,
    /// `--light-radius`), `sphere` (`--light-radius`).
    #[arg(long, value_enum, default_value = "point")]
    light_shape: Shape,
    /// Directional: the direction its light travels; spot: its cone's
    /// axis, `X,Y,Z`.
    #[arg(long, value_parser = crate::vec3::parse, allow_hyphen_values = true)]
    light_direction: Option<Vec3>,
    /// Spot: the angle between its axis and its cone's edge, degrees.
    #[arg(long)]
    light_half_angle: Option<f32>,
    /// Rectangle: half edge `X,Y,Z`.
    #[arg(long, value_parser = crate::vec3::parse, allow_hyphen_values = true)]
    light_u: Option<Vec3>,
    /// Rectangle: the other half edge `X,Y,Z`.
    #[arg(long, value_parser = crate::vec3::parse, allow_hyphen_values = true)]
    light_v: Option<Vec3>,
    /// Disk: the side it faces, `X,Y,Z`.
    #[arg(long, value_parser = crate::vec3::parse, allow_hyphen_values = true)]
    light_normal: Option<Vec3>,
    /// Disk or sphere radius, metres.
    #[arg(long)]
    light_radius: Option<f32>,
    /// Area lights: `N` gives `N x N` samples per pixel.
    #[arg(long)]
    samples: Option<u32>,
    /// Area lights: the samples' seed.
    #[arg(long)]
    seed: Option<u64>,
    #[arg(long, value_enum, default_value = "auto")]
    method: Method,
    /// Side of each light-map face, texels.
    #[arg(long)]
    shadow_map_size: Option<u32>,
    /// The PNG written.
    #[arg(long)]
    out: PathBuf,
}

impl ShadowArgs {
    fn request(&self) -> ShadowRequest {
        ShadowRequest {
            camera: CameraSpec {
                position: self.camera.to_array(),
                look_at: self.look_at.to_array(),
                up: self.up.to_array(),
                fov_y_deg: self.fov,
                width: self.width,
                height: self.height,
            },
            light: LightSpec {
                shape: match self.light_shape {
                    Shape::Point => LightShape::Point,
                    Shape::Spot => LightShape::Spot,
                    Shape::Directional => LightShape::Directional,
                    Shape::Rectangle => LightShape::Rectangle,
                    Shape::Disk => LightShape::Disk,
                    Shape::Sphere => LightShape::Sphere,
                },
                u: self.light_u.map(|v| v.to_array()),
                v: self.light_v.map(|v| v.to_array()),
                normal: self.light_normal.map(|v| v.to_array()),
                radius: self.light_radius,
                position: self.light.map(|v| v.to_array()),
                direction: self.light_direction.map(|v| v.to_array()),
                half_angle_deg: self.light_half_angle,
            },
            method: match self.method {
                Method::Auto => ShadowMethod::Auto,
                Method::Selective => ShadowMethod::Selective,
                Method::Full => ShadowMethod::Full,
                Method::ShadowMap => ShadowMethod::ShadowMap,
            },
            shadow_map_size: self.shadow_map_size,
            samples: self.samples,
            seed: self.seed,
        }
    }
}

pub fn run(args: &ShadowArgs) -> Result<(), Box<dyn Error>> {
    let path = args
        .scene
        .as_ref()
        .ok_or("give --scene FILE or --scene-id ID")?;
    let scene = Scene::load(path)?;
    let world = SceneBvh::build(&scene, &BuildOptions::default());
    let (camera, light, options) = args.request().engine()?;
    let image = ShadowScene::new(&world).shadows(&world, &camera, &light, &options)?;
    std::fs::write(&args.out, png(&image)?)?;
    report(
        &args.out,
        image.stats.receivers,
        image.stats.pip_pixels,
        image.stats.total_ms,
    );
    Ok(())
}

pub fn run_remote(client: &Client, id: &str, args: &ShadowArgs) -> Result<(), Box<dyn Error>> {
    let answer = client.shadows(id, &args.request())?;
    let bytes = png_of_levels(answer.width, answer.height, &answer.visibility)?;
    std::fs::write(&args.out, bytes)?;
    let s = &answer.stats;
    report(&args.out, s.receivers, s.pip_pixels, s.total_ms);
    Ok(())
}

fn report(out: &std::path::Path, receivers: u64, traced: u64, ms: f64) {
    eprintln!(
        "{}: {receivers} pixels see a surface, {traced} traced, {ms:.1} ms",
        out.display()
    );
}
