//! `frusta ir`: the impulse response from one source to one listener, its
//! paths and ISO 3382-1 parameters, as text or JSON, optionally as WAV.
//! With `--scene-id` the server computes it (`remote::ir`).

use std::error::Error;
use std::path::PathBuf;

use clap::Args;
use frusta_engine::acoustics::signal::write_wav;
use frusta_engine::acoustics::{simulate, AcousticScene};
use frusta_engine::scene::generate::BoxRoom;
use frusta_engine::scene::{Material, Scene};
use glam::Vec3;

use crate::simulation_args::SimulationArgs;
use crate::{report, vec3};

#[derive(Args)]
pub struct IrArgs {
    /// Scene file (`.json`, `.obj`, `.gltf`, `.glb`).
    #[arg(
        long,
        conflicts_with_all = ["shoebox", "scene_id"],
        required_unless_present_any = ["shoebox", "scene_id"]
    )]
    scene: Option<PathBuf>,
    /// Instead of a scene: an axis-aligned box room from the origin to `LX,LY,LZ`.
    #[arg(long, value_parser = vec3::parse, requires = "absorption", conflicts_with = "scene_id")]
    shoebox: Option<Vec3>,
    /// Energy absorption of every wall of `--shoebox`, all bands.
    #[arg(long)]
    absorption: Option<f32>,
    /// Instead of a scene file: the id of a scene on the server (`--server`),
    /// which computes the response.
    #[arg(long)]
    pub scene_id: Option<String>,
    #[command(flatten)]
    pub simulation: SimulationArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write the impulse response as 32-bit float WAV.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

impl IrArgs {
    fn scene(&self) -> Result<Scene, Box<dyn Error>> {
        match (&self.scene, self.shoebox) {
            (Some(path), _) => Ok(Scene::load(path)?),
            (None, Some(size)) => {
                let absorption = self.absorption.unwrap_or_default();
                let room = BoxRoom::new(Vec3::ZERO, size).generate()?;
                Ok(Scene::single_object(
                    "shoebox",
                    room,
                    Material::uniform("walls", absorption)?,
                )?)
            }
            (None, None) => Err("give --scene PATH or --shoebox LX,LY,LZ --absorption A".into()),
        }
    }
}

pub fn run(args: &IrArgs) -> Result<(), Box<dyn Error>> {
    let sim = &args.simulation;
    let scene = AcousticScene::simplified(&args.scene()?, sim.lod_error)?;
    let response = simulate(&scene, &[sim.source], &[sim.listener], &sim.options())?
        .pop()
        .ok_or("no response")?;
    if let Some(path) = &args.out {
        write_wav(path, &response.impulse_response)?;
    }
    report::print(&(&response).into(), args.json, args.out.as_deref())
}
