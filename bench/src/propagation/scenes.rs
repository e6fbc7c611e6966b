//! The benchmark scenes with one fixed source and listener each.

use std::path::Path;

use frusta_engine::scene::generate::BoxRoom;
use frusta_engine::scene::{Material, Scene};
use glam::{DVec3, Vec3};

/// A scene, its source and its listener.
pub struct BenchScene {
    pub scene: Scene,
    pub source: DVec3,
    pub listener: DVec3,
    /// Highest order swept.
    pub max_order: u32,
    /// Whether pyroomacoustics runs on it (small rooms only).
    pub peer: bool,
}

/// Scene names in sweep order.
pub const NAMES: &[&str] = &[
    "shoebox",
    "box-192",
    "l-room",
    "two-rooms",
    "hall-10k",
    "hall-200k",
];

/// Source and listener per scene: inside the air volume, away from walls,
/// pillars, seats and the stage (see `engine/src/scene/generate`).
pub fn points(name: &str) -> (DVec3, DVec3) {
    match name {
        // 10 x 6 x 3 m box (also the peer's self-test points).
        "shoebox" | "box-192" => (DVec3::new(2.0, 3.0, 1.5), DVec3::new(7.3, 4.1, 1.7)),
        // 12 x 10 x 3 m minus the corner x > 7, y > 6: one point in each arm.
        "l-room" => (DVec3::new(10.5, 2.0, 1.5), DVec3::new(2.5, 8.0, 1.7)),
        // room A x in [0, 5], partition [5, 5.2], room B [5.2, 10.2]; 4 m deep.
        "two-rooms" => (DVec3::new(1.5, 1.2, 1.5), DVec3::new(8.5, 2.8, 1.6)),
        // 40 x 24 x 16 m hall: source 1.5 m above the stage (x < 6, top at
        // 1 m), listener at ear height over the left seat block (seats are
        // 0.5 m tall, x in [10, 38], y in [6, 11.04]), clear of the pillars
        // at y = 4.8 and 19.2.
        _ => (DVec3::new(3.0, 12.0, 2.5), DVec3::new(22.0, 9.0, 1.7)),
    }
}

pub fn load(name: &'static str, quick: bool) -> Result<BenchScene, String> {
    let scene = if name == "box-192" {
        let room = BoxRoom {
            min: Vec3::ZERO,
            max: Vec3::new(10.0, 6.0, 3.0),
            subdivisions: 4,
            ..BoxRoom::new(Vec3::ZERO, Vec3::ONE)
        };
        let mesh = room.generate().map_err(|e| e.to_string())?;
        let walls = Material::uniform("walls", 0.1).map_err(|e| e.to_string())?;
        Scene::single_object("room", mesh, walls).map_err(|e| e.to_string())?
    } else {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}.json"));
        Scene::load(&path).map_err(|e| format!("{}: {e}", path.display()))?
    };
    let (source, listener) = points(name);
    let max_order = match (name, quick) {
        (_, true) => 4,
        ("shoebox", false) => 6,
        _ => 4,
    };
    Ok(BenchScene {
        scene,
        source,
        listener,
        max_order,
        peer: matches!(name, "shoebox" | "box-192" | "l-room"),
    })
}
