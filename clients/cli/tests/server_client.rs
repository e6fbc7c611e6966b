//! Runs the `frusta` binary against the real server, started in-process on
//! a free loopback port over a fresh data directory holding the shoebox.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

use serde_json::Value;

const SHOEBOX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/shoebox.json");

/// A 4 x 3 x 2.5 m closed box, written by the tests as a scene document.
const BOX_DOC: &str = r#"{
  "name": "small box",
  "materials": { "walls": "plaster" },
  "objects": [
    { "name": "room", "material": "walls",
      "mesh": { "box_room": { "min": [0, 0, 0], "max": [4, 3, 2.5], "subdivisions": 1 } } }
  ]
}"#;

/// A server over a directory of its own. Fields drop in order: the server
/// stops before its directory is removed.
struct Server {
    server: frusta_server::BackgroundServer,
    dir: TempDir,
}

struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

impl Server {
    fn start() -> Self {
        Self::start_with(|_| {})
    }

    /// A server whose configuration `change` has adjusted.
    fn start_with(change: impl FnOnce(&mut frusta_server::Config)) -> Self {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "frusta-cli-server-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        let scenes = dir.join("scenes");
        std::fs::create_dir_all(&scenes).expect("temp dir");
        // Only the shoebox, so that startup builds nothing large.
        std::fs::copy(SHOEBOX, scenes.join("shoebox.json")).expect("copy the shoebox");
        let mut config = frusta_server::Config::with_data_dir(dir.join("data"));
        config.scenes_dir = scenes;
        config.addr = "127.0.0.1:0".parse().expect("address");
        change(&mut config);
        Self {
            server: frusta_server::BackgroundServer::start(config).expect("start the server"),
            dir: TempDir(dir),
        }
    }

    /// `frusta --server URL ARGS...`.
    fn frusta(&self, args: &[&str]) -> Output {
        self.command(args).output().expect("run frusta")
    }

    fn command(&self, args: &[&str]) -> Command {
        let mut command = Command::new(env!("CARGO_BIN_EXE_frusta"));
        command
            .arg("--server")
            .arg(self.server.url())
            .args(args)
            .env_remove("FRUSTA_API_KEY");
        command
    }

    /// A file in the server's temporary directory.
    fn file(&self, name: &str, contents: &str) -> PathBuf {
        let path = self.dir.0.join(name);
        std::fs::write(&path, contents).expect("write");
        path
    }
}

fn stdout(out: &Output) -> String {
    assert!(out.status.success(), "{out:?}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn stdout_json(out: &Output) -> Value {
    serde_json::from_str(&stdout(out)).expect("JSON on stdout")
}

fn path_str(path: &Path) -> &str {
    path.to_str().expect("UTF-8 path")
}

#[test]
fn scenes_are_listed_uploaded_and_deleted() {
    let server = Server::start();
    let text = stdout(&server.frusta(&["scenes", "list"]));
    let shoebox = text
        .lines()
        .find(|l| l.starts_with("shoebox "))
        .unwrap_or_else(|| panic!("no shoebox row in\n{text}"));
    let columns: Vec<&str> = shoebox.split_whitespace().collect();
    assert_eq!(columns[1..], ["12", "1", "0"], "{text}");

    let doc = server.file("small-box.json", BOX_DOC);
    let id = stdout(&server.frusta(&["scenes", "upload", path_str(&doc)]));
    // Without --id the server names the scene after the file.
    assert_eq!(id.trim(), "small-box");
    let id = stdout(&server.frusta(&["scenes", "upload", path_str(&doc), "--id", "mine"]));
    assert_eq!(id.trim(), "mine");
    let mine = listed(&server, "mine");
    assert_eq!(mine["triangles"], 12);
    assert_eq!(mine["materials"][0], "walls");

    assert_eq!(
        stdout(&server.frusta(&["scenes", "delete", "mine"])).trim(),
        "deleted mine"
    );
    let text = stdout(&server.frusta(&["scenes", "list"]));
    assert!(!text.lines().any(|l| l.starts_with("mine ")), "{text}");
    let again = server.frusta(&["scenes", "delete", "mine"]);
    assert!(!again.status.success());
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert!(
        stderr.contains("error: Unknown scene: no scene with id `mine`"),
        "{stderr}"
    );
}

#[test]
fn a_document_that_references_a_mesh_file_is_uploaded_with_the_mesh() {
    let server = Server::start();
    server.file("panel.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let doc = server.file(
        "with-file.json",
        r#"{"objects": [{"name": "panel", "material": "concrete", "mesh": {"file": "panel.obj"}}]}"#,
    );
    let id = stdout(&server.frusta(&["scenes", "upload", path_str(&doc)]));
    assert_eq!(id.trim(), "with-file");
    let scene = listed(&server, "with-file");
    assert_eq!(scene["triangles"], 1);
}

#[test]
fn an_obj_upload_is_one_object_named_after_the_file() {
    let server = Server::start();
    let obj = server.file("panel.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let id = stdout(&server.frusta(&["scenes", "upload", path_str(&obj), "--id", "tri"]));
    assert_eq!(id.trim(), "tri");
    let tri = listed(&server, "tri");
    assert_eq!(tri["objects"][0]["name"], "panel");
    assert_eq!(tri["triangles"], 1);
}

#[test]
fn ir_on_the_server_matches_ir_offline() {
    let server = Server::start();
    let flags = [
        "--source",
        "2,3,1.5",
        "--listener",
        "7.1,2.3,1.2",
        "--max-order",
        "3",
        "--sampling",
        "6",
        "--sample-rate",
        "16000",
        "--no-air",
        "--json",
    ];
    let offline = stdout_json(&server.frusta(&[&["ir", "--scene", SHOEBOX], &flags[..]].concat()));
    let remote =
        stdout_json(&server.frusta(&[&["ir", "--scene-id", "shoebox"], &flags[..]].concat()));
    let paths = |doc: &Value| doc["paths"].as_array().expect("paths").clone();
    let (offline_paths, remote_paths) = (paths(&offline), paths(&remote));
    // 1 + 6 + 18 + 38 image sources of a closed box to order 3.
    assert_eq!(offline_paths.len(), 63);
    assert_eq!(remote_paths.len(), offline_paths.len());
    for (a, b) in offline_paths.iter().zip(&remote_paths) {
        let d = |p: &Value| p["distance_m"].as_f64().expect("distance");
        assert!((d(a) - d(b)).abs() < 1e-6, "{a} vs {b}");
        assert_eq!(a["order"], b["order"]);
    }
    assert_eq!(remote["sample_rate"], 16000);

    // With --lod-error on the shoebox: at 0.5 m its flat walls stay as
    // they are, so both answer on the exact geometry and say so (bound 0);
    // at 8 m the room is one rectangle (its one node's error is about
    // 6.7 m), and both say 8 and agree on the paths.
    let ask = |bound: &str| {
        let lod = [&flags[..], &["--lod-error", bound]].concat();
        let offline =
            stdout_json(&server.frusta(&[&["ir", "--scene", SHOEBOX], &lod[..]].concat()));
        let remote =
            stdout_json(&server.frusta(&[&["ir", "--scene-id", "shoebox"], &lod[..]].concat()));
        (offline, remote)
    };
    let (offline_lod, remote_lod) = ask("0.5");
    for doc in [&offline_lod, &remote_lod] {
        assert_eq!(doc["stats"]["lod_error_m"], 0.0, "{doc}");
        assert_eq!(paths(doc).len(), 63);
    }
    let (offline_lod, remote_lod) = ask("8");
    for doc in [&offline_lod, &remote_lod] {
        assert_eq!(doc["stats"]["lod_error_m"], 8.0, "{doc}");
    }
    assert!(paths(&remote_lod).len() < 63);
    assert_eq!(paths(&remote_lod).len(), paths(&offline_lod).len());
    assert_eq!(offline["stats"]["lod_error_m"], 0.0);

    // The text report is the offline one, and --out writes the server's WAV.
    let wav = server.dir.0.join("ir.wav");
    let text = stdout(&server.frusta(&[
        "ir",
        "--scene-id",
        "shoebox",
        "--source",
        "2,3,1.5",
        "--listener",
        "7,2,1.2",
        "--max-order",
        "2",
        "--binaural",
        "--out",
        path_str(&wav),
    ]));
    assert!(text.starts_with("25 paths,"), "{text}");
    assert!(text.contains("band Hz    EDT s"), "{text}");
    assert!(text.contains("wrote "), "{text}");
    let (rate, channels) = frusta_engine::acoustics::signal::read_wav(&wav).expect("WAV");
    assert_eq!((rate, channels.len()), (48_000, 2));
}

#[test]
fn server_problems_are_errors_with_their_detail() {
    let server = Server::start();
    let run = |command: &str, scene: &str, order: &str| {
        server.frusta(&[
            command,
            "--scene-id",
            scene,
            "--source",
            "2,3,1.5",
            "--listener",
            "7,2,1.2",
            "--max-order",
            order,
        ])
    };
    let unknown = "error: Unknown scene: no scene with id `no-such-scene`";
    let limit = "error: Limit exceeded: max_order 9 exceeds this server's limit of 8";
    for (out, message) in [
        (run("ir", "no-such-scene", "2"), unknown),
        (run("ir", "shoebox", "9"), limit),
        // Refused at the upgrade (HTTP), then in an error frame.
        (run("stream", "no-such-scene", "2"), unknown),
        (run("stream", "shoebox", "9"), limit),
    ] {
        assert!(!out.status.success(), "{out:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(message), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }

    // Server commands without a server say what is missing.
    let out = Command::new(env!("CARGO_BIN_EXE_frusta"))
        .args(["scenes", "list"])
        .env_remove("FRUSTA_SERVER")
        .output()
        .expect("run frusta");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--server URL"));
}

#[test]
fn stream_answers_every_update_of_a_moving_listener() {
    let server = Server::start();
    let args = [
        "stream",
        "--scene-id",
        "shoebox",
        "--source",
        "2,3,1.5",
        "--listener",
        "7,2,1.2",
        "--to",
        "8,4,1.2",
        "--updates",
        "5",
        "--max-order",
        "2",
        "--cells",
        "sampled",
    ];
    let text = stdout(&server.frusta(&args));
    let rows: Vec<&str> = text
        .lines()
        .filter(|l| l.trim_start().starts_with(|c: char| c.is_ascii_digit()))
        .filter(|l| !l.contains("updates in"))
        .collect();
    assert_eq!(rows.len(), 5, "{text}");
    for (seq, row) in rows.iter().enumerate() {
        let columns: Vec<&str> = row.split_whitespace().collect();
        assert_eq!(columns[0], seq.to_string(), "{row}");
        assert_eq!(columns[3], "25", "{row}");
    }
    assert!(text.contains("5 updates in"), "{text}");
    assert!(text.contains("p99"), "{text}");

    let out = server.frusta(&[&args[..], &["--json"]].concat());
    let lines: Vec<Value> = stdout(&out)
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object per line"))
        .collect();
    assert_eq!(lines.len(), 6);
    // The source stays put, so after the first update its beams are reused.
    assert_eq!(lines[0]["beams_reused"], false);
    assert!(lines[1..5].iter().all(|l| l["beams_reused"] == true));
    assert_eq!(lines[5]["updates"], 5);
    assert!(lines[5]["latency_p99_ms"].as_f64() >= lines[5]["latency_p50_ms"].as_f64());
}

#[test]
fn the_api_key_comes_from_the_flag_or_the_environment() {
    let server = Server::start_with(|config| config.api_keys = vec!["sesame".into()]);
    let out = server.frusta(&["scenes", "list"]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("error: Unauthorized: missing or unknown API key"),
        "{stderr}"
    );

    let text = stdout(&server.frusta(&["--api-key", "sesame", "scenes", "list"]));
    assert!(text.contains("shoebox"), "{text}");
    let out = server
        .command(&["stream", "--scene-id", "shoebox", "--source", "2,3,1.5"])
        .args([
            "--listener",
            "7,2,1.2",
            "--updates",
            "1",
            "--max-order",
            "1",
        ])
        .env("FRUSTA_API_KEY", "sesame")
        .output()
        .expect("run frusta");
    assert!(stdout(&out).contains("1 updates in"));
}

/// The scene `id` as `frusta scenes list --json` shows it.
fn listed(server: &Server, id: &str) -> serde_json::Value {
    let list = stdout_json(&server.frusta(&["scenes", "list", "--json"]));
    list["scenes"]
        .as_array()
        .expect("scenes")
        .iter()
        .find(|s| s["id"] == id)
        .unwrap_or_else(|| panic!("{id} is not listed: {list}"))
        .clone()
}

/// Two closed 1 m crates, a metre apart along x.
const CRATES: &str = r#"{
  "name": "crates",
  "materials": {"wood": {"absorption": 0.1}},
  "objects": [
    {"name": "a", "material": "wood", "mesh": {"box_room": {"min": [1, 1, 1], "max": [2, 2, 2]}}},
    {"name": "b", "material": "wood", "mesh": {"box_room": {"min": [3, 1, 1], "max": [4, 2, 2]}}}
  ]
}"#;

#[test]
fn collide_answers_alike_here_and_on_the_server() {
    let server = Server::start();
    let doc = server.file("crates.json", CRATES);
    let id = stdout(&server.frusta(&["scenes", "upload", path_str(&doc)]));
    assert_eq!(id.trim(), "crates");
    let sweep = [
        "collide",
        "--kind",
        "continuous",
        "--move",
        "b=-1.5,0,0",
        "--json",
    ];
    let here = stdout_json(&server.frusta(&[&sweep[..], &["--scene", path_str(&doc)]].concat()));
    let there = stdout_json(&server.frusta(&[&sweep[..], &["--scene-id", "crates"]].concat()));
    let t = here["earliest_time"].as_f64().expect("the crates meet");
    assert!(t <= 2.0 / 3.0 && t > 2.0 / 3.0 - 1e-4, "{t}");
    assert_eq!(here["contacts"], there["contacts"]);
    assert_eq!(here["total"], there["total"]);
    assert_eq!(there["revision"], 1, "the move is stored on the server");
    // After the move the crates overlap there; here the file is unmoved.
    let after = stdout(&server.frusta(&["collide", "--scene-id", "crates"]));
    assert!(!after.trim_end().ends_with(" 0 contacts"), "{after}");
    let here = stdout(&server.frusta(&["collide", "--scene", path_str(&doc)]));
    assert_eq!(here.trim(), "0 contacts");
    let bad = server.frusta(&["collide", "--scene-id", "crates", "--pair", "a,c"]);
    assert!(!bad.status.success());
    assert!(
        String::from_utf8_lossy(&bad.stderr).contains("Unknown object"),
        "{bad:?}"
    );
}

/// A room with a panel hanging in it.
const PANEL_ROOM: &str = r#"{
  "materials": {"walls": {"absorption": 0.1}},
  "objects": [
    {"name": "room", "material": "walls",
     "mesh": {"box_room": {"min": [0, 0, 0], "max": [10, 6, 3]}}},
    {"name": "panel", "material": "walls",
     "mesh": {"vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, 2], [4, 1, 2]],
              "triangles": [[0, 1, 2], [0, 2, 3]]}}
  ]
}"#;

/// Draws `view` (a `frusta shadows` command up to `--out`) of the panel
/// room from its file and on a server, checks both PNGs hold the same
/// bytes and returns their grey levels; `broken`, the view with a flaw,
/// must fail naming `flaw`.
fn shadows_here_and_there(view: &[&str], broken: &[&str], flaw: &str) -> Vec<u8> {
    shadows_of_scene_here_and_there(PANEL_ROOM, view, broken, flaw)
}

/// [`shadows_here_and_there`] of the scene document `scene`.
fn shadows_of_scene_here_and_there(
    scene: &str,
    view: &[&str],
    broken: &[&str],
    flaw: &str,
) -> Vec<u8> {
    let server = Server::start();
    let doc = server.file("scene.json", scene);
    let id = stdout(&server.frusta(&["scenes", "upload", path_str(&doc)]));
    let (here, there) = (
        server.dir.0.join("here.png"),
        server.dir.0.join("there.png"),
    );
    stdout(&server.frusta(&[view, &[path_str(&here), "--scene", path_str(&doc)]].concat()));
    stdout(&server.frusta(&[view, &[path_str(&there), "--scene-id", id.trim()]].concat()));
    let bytes = std::fs::read(&here).expect("PNG here");
    assert_eq!(bytes, std::fs::read(&there).expect("PNG there"));
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .expect("a PNG");
    let mut pixels = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut pixels).expect("a frame");
    assert_eq!((info.width, info.height), (48, 32));
    pixels.truncate(info.buffer_size());
    let bad = server.frusta(&[broken, &[path_str(&here), "--scene-id", id.trim()]].concat());
    assert!(!bad.status.success());
    assert!(
        String::from_utf8_lossy(&bad.stderr).contains(flaw),
        "{bad:?}"
    );
    pixels
}

const PANEL_VIEW: [&str; 12] = [
    "shadows",
    "--camera",
    "1,1,2.5",
    "--look-at",
    "6,4,0",
    "--light",
    "5,3,2.8",
    "--width",
    "48",
    "--height",
    "32",
    "--out",
];

#[test]
fn shadows_draw_the_same_png_here_and_on_the_server() {
    let mut flat = PANEL_VIEW;
    flat[8] = "0";
    let pixels = shadows_here_and_there(&PANEL_VIEW, &flat, "camera.width");
    assert!(
        pixels.contains(&0) && pixels.contains(&255),
        "the panel casts a shadow"
    );
}

#[test]
fn soft_shadows_draw_the_same_png_here_and_on_the_server() {
    let disk = [
        "--light-shape",
        "disk",
        "--light-normal",
        "0,0,-1",
        "--samples",
        "3",
    ];
    let view = [
        &PANEL_VIEW[..7],
        &disk,
        &["--light-radius", "0.4"],
        &PANEL_VIEW[7..],
    ]
    .concat();
    // A disk without its radius.
    let broken = [&PANEL_VIEW[..7], &disk, &PANEL_VIEW[7..]].concat();
    let pixels = shadows_here_and_there(&view, &broken, "radius");
    assert!(
        pixels.iter().any(|p| *p > 0 && *p < 255),
        "the disk casts a penumbra"
    );
}

#[test]
fn sunlit_shadows_draw_the_same_png_here_and_on_the_server() {
    // The panel over a floor, open to the sky.
    let yard = PANEL_ROOM.replace(
        r#""mesh": {"box_room": {"min": [0, 0, 0], "max": [10, 6, 3]}}"#,
        r#""mesh": {"vertices": [[0, 0, 0], [10, 0, 0], [10, 6, 0], [0, 6, 0]],
                    "triangles": [[0, 1, 2], [0, 2, 3]]}"#,
    );
    let sun = [
        "--light-shape",
        "directional",
        "--light-direction",
        "0.6,0.2,-1",
    ];
    let view = [&PANEL_VIEW[..5], &sun, &PANEL_VIEW[7..]].concat();
    assert_ne!(yard, PANEL_ROOM);
    // A directional light has no position.
    let broken = [&PANEL_VIEW[..7], &sun, &PANEL_VIEW[7..]].concat();
    let pixels = shadows_of_scene_here_and_there(&yard, &view, &broken, "position");
    assert!(
        pixels.contains(&0) && pixels.contains(&255),
        "the panel casts a shadow in the sun"
    );
}
