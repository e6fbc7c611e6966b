//! `frusta collide`: which triangles of a scene's objects touch, come
//! within a distance, or meet while objects move, here or (with
//! `--scene-id`) on the server, with the same answer either way.

use std::error::Error;
use std::path::PathBuf;

use clap::ValueEnum;
use frusta_client::api::collisions::{
    object_by_name, CollisionKind, CollisionRequest, CollisionResponse,
};
use frusta_client::api::objects::{ObjectMove, ObjectPatch};
use frusta_client::Client;
use frusta_engine::bvh::{BuildOptions, SceneBvh};
use frusta_engine::collision::continuous::EndPose;
use frusta_engine::collision::CollisionTest;
use frusta_engine::geometry::RigidTransform;
use frusta_engine::scene::Scene;
use glam::Vec3;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Kind {
    /// Triangles that intersect, after the moves.
    Discrete,
    /// Triangles within `--distance`, after the moves.
    Proximity,
    /// Triangles that meet while the objects move to `--move`.
    Continuous,
}

#[derive(clap::Args)]
pub struct CollideArgs {
    /// Scene file (`.json`, `.obj`, `.gltf`, `.glb`), for a query here.
    #[arg(
        long,
        conflicts_with = "scene_id",
        required_unless_present = "scene_id"
    )]
    scene: Option<PathBuf>,
    /// A scene on the server (needs `--server`); the moves are stored there.
    #[arg(long)]
    pub scene_id: Option<String>,
    #[arg(long, value_enum, default_value = "discrete")]
    kind: Kind,
    /// Object pair `A,B` (names or indices); repeatable. Default: every
    /// pair, unless `--self` is given.
    #[arg(long = "pair", value_name = "A,B", value_parser = parse_pair)]
    pairs: Vec<[String; 2]>,
    /// Object tested against itself; repeatable.
    #[arg(long = "self", value_name = "OBJECT")]
    selves: Vec<String>,
    /// Proximity: the largest distance reported, metres.
    #[arg(long)]
    distance: Option<f64>,
    /// Continuous: distance at which moving triangles count as touching.
    #[arg(long)]
    tolerance: Option<f64>,
    /// Object moved to translation `X,Y,Z` (its rotation kept), as
    /// `OBJECT=X,Y,Z`; repeatable.
    #[arg(long = "move", value_name = "OBJECT=X,Y,Z", value_parser = parse_move, allow_hyphen_values = true)]
    moves: Vec<(String, Vec3)>,
    /// Most contacts listed.
    #[arg(long, default_value_t = 1000)]
    max_contacts: usize,
    /// Print JSON (the server's answer) instead of text.
    #[arg(long)]
    json: bool,
}

fn parse_pair(text: &str) -> Result<[String; 2], String> {
    match text.split_once(',') {
        Some((a, b)) if !a.is_empty() && !b.is_empty() => Ok([a.to_owned(), b.to_owned()]),
        _ => Err(format!("expected A,B (two objects), got `{text}`")),
    }
}

fn parse_move(text: &str) -> Result<(String, Vec3), String> {
    let (object, at) = text
        .split_once('=')
        .ok_or_else(|| format!("expected OBJECT=X,Y,Z, got `{text}`"))?;
    Ok((object.to_owned(), crate::vec3::parse(at)?))
}

impl CollideArgs {
    fn request(&self) -> CollisionRequest {
        CollisionRequest {
            kind: match self.kind {
                Kind::Discrete => CollisionKind::Discrete,
                Kind::Proximity => CollisionKind::Proximity,
                Kind::Continuous => CollisionKind::Continuous,
            },
            pairs: (!self.pairs.is_empty()).then(|| self.pairs.clone()),
            self_objects: self.selves.clone(),
            distance: self.distance,
            tolerance: self.tolerance,
            moves: self
                .moves
                .iter()
                .map(|(object, at)| ObjectMove {
                    object: object.clone(),
                    patch: ObjectPatch {
                        translation: Some(at.to_array()),
                        ..Default::default()
                    },
                })
                .collect(),
            max_contacts: Some(self.max_contacts),
        }
    }
}

/// On the server: the request as the route takes it.
pub fn run_remote(client: &Client, id: &str, args: &CollideArgs) -> Result<(), Box<dyn Error>> {
    let answer = client.collisions(id, &args.request())?;
    print(&answer, args.json)
}

/// Here: the scene loaded and built, the query run by the engine as the
/// server runs it.
pub fn run(args: &CollideArgs) -> Result<(), Box<dyn Error>> {
    let path = args
        .scene
        .as_ref()
        .ok_or("give --scene FILE or --scene-id ID")?;
    let scene = Scene::load(path)?;
    let names: Vec<String> = scene.objects.iter().map(|o| o.name.clone()).collect();
    let request = args.request();
    let query = request.query(&names)?;
    let moved = args
        .moves
        .iter()
        .map(|(object, at)| {
            let o = object_by_name(&names, object)?;
            let rotation = scene.objects[o as usize].transform.rotation;
            Ok((o, RigidTransform::new(rotation, *at)?))
        })
        .collect::<Result<Vec<_>, Box<dyn Error>>>()?;
    let mut world = SceneBvh::build(&scene, &BuildOptions::default());
    let found = if matches!(query.test, CollisionTest::Continuous { .. }) {
        let ends: Vec<(u32, EndPose)> =
            moved.iter().map(|(o, t)| (*o, EndPose::Moved(t))).collect();
        query.run_during(&world, &ends, None, None)?
    } else {
        for (o, t) in &moved {
            world.set_transform(*o as usize, *t)?;
        }
        query.run(&world, None, None)?
    };
    let answer = CollisionResponse::new(0, request.kind, found, &names, args.max_contacts);
    print(&answer, args.json)
}

fn print(answer: &CollisionResponse, json: bool) -> Result<(), Box<dyn Error>> {
    if json {
        println!("{}", serde_json::to_string_pretty(answer)?);
        return Ok(());
    }
    for c in &answer.contacts {
        let mut line = format!(
            "{}:{}  {}:{}",
            c.a.object, c.a.triangle, c.b.object, c.b.triangle
        );
        if let Some(d) = c.distance {
            line += &format!("  distance {d:.6} m");
        }
        if let Some(t) = c.time {
            line += &format!("  time {t:.6}");
        }
        println!("{line}");
    }
    let shown = if answer.truncated {
        format!(" ({} listed)", answer.contacts.len())
    } else {
        String::new()
    };
    match answer.earliest_time {
        Some(t) => println!("{} contacts{shown}; earliest at time {t:.6}", answer.total),
        None => println!("{} contacts{shown}", answer.total),
    }
    Ok(())
}
