//! `frusta-bench shadows`: hard shadows of a moving point light and of
//! the sun (a directional light, turning), and soft shadows of a moving
//! area light per frame, the plain shadow map,
//! selective ray tracing and full ray tracing side by side, interleaved
//! frame by frame; the light map is rebuilt every frame. Then the receiver
//! form: which of 10,000 seats see a source on the stage, selective
//! against one ray (or one set of samples) per seat.
//! Every method shares the frame's G-buffer (rasterised, timed apart), so
//! each method's time is its shadow work alone, and selective must match
//! full on every pixel. The scene's shadow data (world-space triangles,
//! welded edges and parts) is made once, as for a static scene whose light
//! moves, and timed apart too.

use std::path::{Path, PathBuf};

use frusta_engine::bvh::{BuildOptions, SceneBvh};
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use frusta_engine::scene::generate::BoxRoom;
use frusta_engine::scene::{Material, Scene, SceneObject};
use frusta_engine::shadows::{
    AreaLight, AreaShape, Camera, DirectionalLight, Light, Method, PointLight, PointVisibility,
    ShadowImage, ShadowOptions, ShadowScene,
};
use glam::Vec3;
use serde::Serialize;

use crate::provenance::{self, Provenance};
use crate::stats::median;

/// Scenes in run order.
const SCENES: &[&str] = &["hall-10k", "hall-200k", "bunny-room"];

#[derive(clap::Args)]
pub struct Args {
    /// Scenes to run (default: all of hall-10k, hall-200k, bunny-room).
    #[arg(long = "scene")]
    scenes: Vec<String>,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 1024)]
    size: u32,
    /// Side of each shadow-map face in texels.
    #[arg(long, default_value_t = ShadowOptions::default().shadow_map_size)]
    map: u32,
    /// Frames, the light moving along a circle.
    #[arg(long, default_value_t = 8)]
    frames: usize,
    /// Soft shadows: samples per side of the area light (16 samples at 4).
    #[arg(long, default_value_t = 4)]
    samples: u32,
    /// Which shadows to run: hard (a point light and the sun), soft (a
    /// panel), or both.
    #[arg(long, value_enum, default_value_t = Kinds::Both)]
    shadows: Kinds,
    /// Print the runs as JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Also write `shadows.txt` and `shadows.json` (with provenance) here.
    #[arg(long)]
    save: Option<PathBuf>,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Kinds {
    Hard,
    Soft,
    Both,
}

/// The light of a run.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Lamp {
    /// A point circling the scene: hard shadows, a perspective map.
    Point,
    /// A directional light at 45 degrees of elevation turning round the
    /// vertical: hard shadows, an orthographic map.
    Sun,
    /// A square panel facing down, circling: soft shadows.
    Panel,
}

impl Lamp {
    fn name(self) -> &'static str {
        match self {
            Lamp::Point => "point",
            Lamp::Sun => "sun",
            Lamp::Panel => "panel",
        }
    }
}

#[derive(Clone, Debug, Serialize)]
struct Run {
    scene: String,
    triangles: usize,
    shadows: &'static str,
    /// `point`, `sun` (directional) or `panel` (area).
    light: &'static str,
    width: u32,
    height: u32,
    shadow_map_size: u32,
    /// Light samples per receiver (1 for hard shadows).
    samples: u32,
    frames: usize,
    /// Medians per frame of each method's shadow work (the G-buffer apart).
    full_ms: f64,
    selective_ms: f64,
    shadow_map_ms: f64,
    gbuffer_ms: f64,
    /// Making the scene's shadow data, once.
    scene_ms: f64,
    /// Selective's phases: light map, classification, tracing the PIP.
    selective_light_map_ms: f64,
    selective_classify_ms: f64,
    selective_trace_ms: f64,
    /// Share of the receivers selective traced, over all frames.
    pip_fraction: f64,
    /// Pixels where selective differs from full, over all frames.
    wrong_pixels: u64,
    /// Pixels where the plain shadow map differs from full.
    shadow_map_wrong_pixels: u64,
    receivers_per_frame: f64,
}

/// Which seats see a source: one query, medians over the rounds.
#[derive(Clone, Debug, Serialize)]
struct Seats {
    scene: String,
    shadows: &'static str,
    points: usize,
    samples: u32,
    rounds: usize,
    full_ms: f64,
    selective_ms: f64,
    /// Share of the points selective traced.
    pip_fraction: f64,
    /// Points where selective differs from full, over all rounds.
    wrong_points: u64,
    /// Share of the points that see all of the source.
    visible_fraction: f64,
}

#[derive(Serialize)]
struct Runs {
    runs: Vec<Run>,
    seats: Vec<Seats>,
}

#[derive(Serialize)]
struct Saved<'a> {
    #[serde(flatten)]
    provenance: Provenance,
    #[serde(flatten)]
    runs: &'a Runs,
}

/// A scene, where the camera looks from and to, and the light's circle:
/// centre and radius.
struct Setup {
    world: SceneBvh,
    triangles: usize,
    eye: Vec3,
    target: Vec3,
    light_centre: Vec3,
    light_radius: f32,
    /// Half side of the square area light.
    light_half: f32,
    /// A source on the stage and the seats' box (halls only).
    stage: Option<(Vec3, Vec3, Vec3)>,
}

fn setup(name: &str) -> Result<Setup, String> {
    let scene = match name {
        "bunny-room" => bunny_room()?,
        _ => {
            let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}.json"));
            Scene::load(&path).map_err(|e| format!("{}: {e}", path.display()))?
        }
    };
    let world = SceneBvh::build(&scene, &BuildOptions::default());
    let (eye, target, light_centre, light_radius, light_half) = match name {
        // The 40 x 24 x 16 m hall from above the back seats towards the
        // stage; the light circles 2 m under the ceiling.
        "hall-10k" | "hall-200k" => (
            Vec3::new(36.0, 12.0, 9.0),
            Vec3::new(8.0, 12.0, 1.0),
            Vec3::new(22.0, 12.0, 14.0),
            6.0,
            0.5,
        ),
        _ => (
            Vec3::new(5.0, 1.2, 2.2),
            Vec3::new(3.0, 3.0, 0.4),
            Vec3::new(3.0, 3.0, 2.6),
            1.2,
            0.2,
        ),
    };
    let stage = name.starts_with("hall").then(|| {
        (
            // 1.5 m above the stage (x < 6 m), and ears 0.7 m above the
            // seat blocks (x from 10 m).
            Vec3::new(3.0, 12.0, 2.5),
            Vec3::new(10.5, 1.5, 1.2),
            Vec3::new(38.0, 22.5, 1.2),
        )
    });
    Ok(Setup {
        triangles: scene.triangle_count(),
        world,
        eye,
        target,
        light_centre,
        light_radius,
        light_half,
        stage,
    })
}

/// The Stanford bunny, about 1.2 m long, on the floor of a 6 x 6 x 3 m
/// room.
fn bunny_room() -> Result<Scene, String> {
    let bunny = crate::mesh::load(&crate::mesh::resolve("stanford-bunny"))?;
    let b = bunny.mesh.bounds();
    let extent = b.max - b.min;
    let k = 1.2 / extent.max_element();
    let base = Vec3::new(
        (b.min.x + b.max.x) * 0.5,
        (b.min.y + b.max.y) * 0.5,
        b.min.z,
    );
    // The bunny's up is +y: turn it to +z.
    let positions = bunny
        .positions()
        .iter()
        .map(|&p| {
            let q = (p - base) * k;
            Vec3::new(q.x + 3.0, -q.z + 3.0, q.y)
        })
        .collect();
    let mesh =
        TriangleMesh::new(positions, bunny.triangles().to_vec()).map_err(|e| e.to_string())?;
    let room = BoxRoom {
        subdivisions: 4,
        ..BoxRoom::new(Vec3::ZERO, Vec3::new(6.0, 6.0, 3.0))
    }
    .generate()
    .map_err(|e| e.to_string())?;
    let room = TriangleMesh::new(room.positions, room.triangles).map_err(|e| e.to_string())?;
    let object = |name: &str, mesh: TriangleMesh| SceneObject {
        name: name.into(),
        materials: vec![0; mesh.triangle_count()],
        mesh,
        transform: RigidTransform::IDENTITY,
        dynamic: false,
    };
    Ok(Scene {
        materials: vec![Material::uniform("plaster", 0.1).map_err(|e| e.to_string())?],
        objects: vec![object("room", room), object("bunny", mesh)],
    })
}

fn differing(a: &ShadowImage, b: &ShadowImage) -> u64 {
    a.visibility
        .iter()
        .zip(&b.visibility)
        .filter(|(x, y)| x != y)
        .count() as u64
}

fn options(method: Method, args: &Args) -> ShadowOptions {
    ShadowOptions {
        method,
        shadow_map_size: args.map,
        samples: args.samples,
        ..ShadowOptions::default()
    }
}

fn run_scene(
    s: &Setup,
    scene: &ShadowScene,
    name: &str,
    lamp: Lamp,
    args: &Args,
) -> Result<Run, String> {
    let soft = lamp == Lamp::Panel;
    let camera = Camera {
        fov_y_deg: 70.0,
        ..Camera::looking_at(s.eye, s.target, args.size, args.size)
    };
    // Soft: a square panel facing down.
    let shadow = |method, centre: Vec3, turn: f32| {
        let light = match lamp {
            Lamp::Panel => {
                let shape = AreaShape::Rectangle {
                    u: Vec3::X * s.light_half,
                    v: Vec3::Y * s.light_half,
                };
                Light::Area(AreaLight { centre, shape })
            }
            Lamp::Point => Light::Point(PointLight { position: centre }),
            Lamp::Sun => Light::Directional(DirectionalLight {
                direction: Vec3::new(turn.cos(), turn.sin(), -1.0),
            }),
        };
        scene
            .shadows(&s.world, &camera, &light, &options(method, args))
            .map_err(|e| e.to_string())
    };
    let mut times: [Vec<f64>; 4] = Default::default();
    let mut phases: [Vec<f64>; 3] = Default::default();
    let (mut wrong, mut plain_wrong, mut pip, mut receivers) = (0, 0, 0, 0);
    for frame in 0..args.frames.max(1) {
        let a = std::f32::consts::TAU * frame as f32 / args.frames.max(1) as f32;
        let light = s.light_centre + Vec3::new(a.cos(), a.sin(), 0.0) * s.light_radius;
        // Rotate which method goes first, so none always runs on a cold
        // cache.
        let mut images: [Option<ShadowImage>; 3] = Default::default();
        for k in 0..3 {
            let m = (frame + k) % 3;
            let method = [Method::Full, Method::Selective, Method::ShadowMap][m];
            images[m] = Some(shadow(method, light, a)?);
        }
        let [full, selective, plain] = images.map(|i| i.expect("every method ran"));
        for (t, img) in times.iter_mut().zip([&full, &selective, &plain]) {
            t.push(img.stats.total_ms - img.stats.gbuffer_ms);
        }
        times[3].push(full.stats.gbuffer_ms);
        let st = &selective.stats;
        for (p, v) in phases
            .iter_mut()
            .zip([st.light_map_ms, st.classify_ms, st.trace_ms])
        {
            p.push(v);
        }
        wrong += differing(&selective, &full);
        plain_wrong += differing(&plain, &full);
        pip += st.pip_pixels;
        receivers += st.receivers;
    }
    let [full_ms, selective_ms, shadow_map_ms, gbuffer_ms] = times.map(median);
    let [light_map_ms, classify_ms, trace_ms] = phases.map(median);
    Ok(Run {
        scene: name.into(),
        triangles: s.triangles,
        shadows: if soft { "soft" } else { "hard" },
        light: lamp.name(),
        width: args.size,
        height: args.size,
        shadow_map_size: args.map,
        samples: if soft { args.samples * args.samples } else { 1 },
        frames: args.frames.max(1),
        full_ms,
        selective_ms,
        shadow_map_ms,
        gbuffer_ms,
        scene_ms: scene.build_ms,
        selective_light_map_ms: light_map_ms,
        selective_classify_ms: classify_ms,
        selective_trace_ms: trace_ms,
        pip_fraction: pip as f64 / receivers.max(1) as f64,
        wrong_pixels: wrong,
        shadow_map_wrong_pixels: plain_wrong,
        receivers_per_frame: receivers as f64 / args.frames.max(1) as f64,
    })
}

pub fn run(args: Args) -> Result<(), String> {
    let mut provenance = provenance::start(rayon::current_num_threads());
    let names: Vec<String> = if args.scenes.is_empty() {
        SCENES.iter().map(|s| s.to_string()).collect()
    } else {
        args.scenes.clone()
    };
    let (mut runs, mut seats) = (Vec::new(), Vec::new());
    let lamps: &[Lamp] = match args.shadows {
        Kinds::Hard => &[Lamp::Point, Lamp::Sun],
        Kinds::Soft => &[Lamp::Panel],
        Kinds::Both => &[Lamp::Point, Lamp::Sun, Lamp::Panel],
    };
    for name in &names {
        if !SCENES.contains(&name.as_str()) {
            return Err(format!("unknown scene {name}; one of {SCENES:?}"));
        }
        let s = setup(name)?;
        let scene = ShadowScene::new(&s.world);
        for &lamp in lamps {
            runs.push(run_scene(&s, &scene, name, lamp, &args)?);
            if let (Some(stage), false) = (s.stage, lamp == Lamp::Sun) {
                let soft = lamp == Lamp::Panel;
                seats.push(run_seats(&s, &scene, name, stage, soft, &args)?);
            }
        }
    }
    provenance.finish();
    let runs = Runs { runs, seats };
    let text = table(&runs, &provenance);
    let saved = Saved {
        provenance,
        runs: &runs,
    };
    provenance::emit(
        "shadows",
        &runs,
        &saved,
        &text,
        args.json,
        args.save.as_deref(),
    )
}

/// Which of 100 x 100 seats see a source on the stage: a point, or (soft)
/// a sphere of 0.3 m radius, a talker or a loudspeaker; the methods
/// alternate first round by round.
fn run_seats(
    s: &Setup,
    scene: &ShadowScene,
    name: &str,
    (source, lo, hi): (Vec3, Vec3, Vec3),
    soft: bool,
    args: &Args,
) -> Result<Seats, String> {
    let n = 100;
    let points: Vec<Vec3> = (0..n * n)
        .map(|k| {
            let (i, j) = (
                (k % n) as f32 / (n - 1) as f32,
                (k / n) as f32 / (n - 1) as f32,
            );
            Vec3::new(lo.x + (hi.x - lo.x) * i, lo.y + (hi.y - lo.y) * j, lo.z)
        })
        .collect();
    let light = if soft {
        Light::Area(AreaLight {
            centre: source,
            shape: AreaShape::Sphere { radius: 0.3 },
        })
    } else {
        Light::Point(PointLight { position: source })
    };
    let ask = |method| -> Result<PointVisibility, String> {
        scene
            .visibility(&s.world, &light, &points, &options(method, args))
            .map_err(|e| e.to_string())
    };
    let rounds = args.frames.max(1);
    let (mut full_ms, mut selective_ms) = (Vec::new(), Vec::new());
    let (mut wrong, mut pip, mut visible) = (0, 0, 0.0);
    for round in 0..rounds {
        let (full, selective) = if round % 2 == 0 {
            let f = ask(Method::Full)?;
            (f, ask(Method::Selective)?)
        } else {
            let sel = ask(Method::Selective)?;
            (ask(Method::Full)?, sel)
        };
        full_ms.push(full.stats.total_ms);
        selective_ms.push(selective.stats.total_ms);
        wrong += full
            .fraction
            .iter()
            .zip(&selective.fraction)
            .filter(|(a, b)| a != b)
            .count() as u64;
        pip += selective.stats.pip_pixels;
        visible = full.fraction.iter().filter(|f| **f == 1.0).count() as f64 / points.len() as f64;
    }
    Ok(Seats {
        scene: name.into(),
        shadows: if soft { "soft" } else { "hard" },
        points: points.len(),
        samples: if soft { args.samples * args.samples } else { 1 },
        rounds,
        full_ms: median(full_ms),
        selective_ms: median(selective_ms),
        pip_fraction: pip as f64 / (rounds * points.len()) as f64,
        wrong_points: wrong,
        visible_fraction: visible,
    })
}

fn table(runs: &Runs, provenance: &Provenance) -> String {
    let mut out = provenance.header();
    out +=
        "\nhard shadows of a point light circling the scene and of the sun (45 degrees up, turning\n";
    out +=
        "round the vertical), soft shadows of a square panel facing down, circling (samples per\n";
    out += "pixel in the table); per frame, medians; each method's\n";
    out +=
        "time excludes the G-buffer every method shares and the scene's shadow data, made once\n";
    out += "(their own columns)\n\n";
    out += "scene        triangles shadows light samples   image  map   full ms  selective ms  (map+classify+trace)     shadow map ms  gbuffer ms  scene ms  full/sel   PIP  wrong  map wrong\n";
    for r in &runs.runs {
        out += &format!(
            "{:<12} {:>9} {:>7} {:>5} {:>7} {:>5}^2 {:>4} {:>9.1} {:>13.1}  ({:>5.1}+{:>4.1}+{:>5.1}) {:>16.1} {:>11.1} {:>9.1} {:>9.2} {:>5.3} {:>6} {:>10}\n",
            r.scene,
            r.triangles,
            r.shadows,
            r.light,
            r.samples,
            r.width,
            r.shadow_map_size,
            r.full_ms,
            r.selective_ms,
            r.selective_light_map_ms,
            r.selective_classify_ms,
            r.selective_trace_ms,
            r.shadow_map_ms,
            r.gbuffer_ms,
            r.scene_ms,
            r.full_ms / r.selective_ms,
            r.pip_fraction,
            r.wrong_pixels,
            r.shadow_map_wrong_pixels
        );
    }
    out += "\nwhich of 100 x 100 seats (ears 0.7 m above the seat blocks) see a source 1.5 m above the\n";
    out += "stage: a point (hard) or a sphere of radius 0.3 m (soft); one query each, medians\n\n";
    out += "scene        shadows samples  points   full ms  selective ms  full/sel   traced  wrong  see all\n";
    for r in &runs.seats {
        out += &format!(
            "{:<12} {:>7} {:>7} {:>7} {:>9.1} {:>13.1} {:>9.2} {:>8.3} {:>6} {:>8.3}\n",
            r.scene,
            r.shadows,
            r.samples,
            r.points,
            r.full_ms,
            r.selective_ms,
            r.full_ms / r.selective_ms,
            r.pip_fraction,
            r.wrong_points,
            r.visible_fraction
        );
    }
    out
}
