//! Every kind of write survives `kill -9` and a plain restart: the real
//! binary, stopped in the middle of a seeded random mix of writes (JSON and
//! OBJ uploads, moves, rotations, JSON and binary vertex edits, material
//! edits, stream object moves, deletes) and restarted on the same data
//! directory, serves exactly what it acknowledged.
//!
//! A model of every scene is kept beside the server. The stop may land
//! after the server stored a write but before this client read the answer,
//! so the one write in flight may or may not be there; everything else must
//! match the model exactly.

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use frusta_api::objects::ObjectPatch;
use frusta_api::stream::{ObjectMove, StreamUpdate};
use frusta_client::{Answer, Client, Config, Error, Received};
use serde_json::Value;

/// A 6 x 5 x 3 m room; a door (a 1 x 2 m quad in the plane x = 3 of its
/// frame, which vertex edits shift along x and moves shift along y and z),
/// and a small panel far from the door, which rotations turn in place.
const ROOM: &str = r#"{"materials": {"walls": {"absorption": 0.2}}, "objects": [
  {"name": "room", "material": "walls", "mesh": {"box_room": {"min": [0, 0, 0], "max": [6, 5, 3], "subdivisions": 2}}},
  {"name": "door", "material": "walls", "dynamic": true,
   "mesh": {"vertices": [[3, 1, 0], [3, 2, 0], [3, 2, 2], [3, 1, 2]], "triangles": [[0, 1, 2], [0, 2, 3]]}},
  {"name": "panel", "material": "walls", "dynamic": true, "transform": {"translation": [5, 4, 2.5]},
   "mesh": {"vertices": [[-0.1, -0.1, 0], [0.1, -0.1, 0], [0.1, 0.1, 0]], "triangles": [[0, 1, 2]]}}]}"#;

const OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n";

/// What a scene should hold.
#[derive(Clone, Debug, PartialEq)]
enum Model {
    Absent,
    /// An OBJ upload: one object, four triangles.
    Mesh,
    Room(Room),
}

#[derive(Clone, Debug, PartialEq)]
struct Room {
    /// The door's translation (y, z).
    door_yz: [f32; 2],
    /// How far vertex edits moved the door along x.
    door_dx: f32,
    panel_rotation: [f32; 4],
    /// Materials added by edits, in order.
    added_materials: Vec<String>,
}

impl Room {
    fn new() -> Self {
        Self {
            door_yz: [0.0, 0.0],
            door_dx: 0.0,
            panel_rotation: [0.0, 0.0, 0.0, 1.0],
            added_materials: Vec::new(),
        }
    }

    /// The door's four vertices for a shift `dx`.
    fn door_vertices(dx: f32) -> [[f32; 3]; 4] {
        let x = 3.0 + dx;
        [[x, 1.0, 0.0], [x, 2.0, 0.0], [x, 2.0, 2.0], [x, 1.0, 2.0]]
    }
}

/// What the client knows: every acknowledged state, and the one write
/// sent but not yet answered (its scene and the state it leads to).
#[derive(Default)]
struct Ledger {
    confirmed: BTreeMap<String, Model>,
    in_flight: Option<(String, Model)>,
    next_id: usize,
}

/// xorshift64*: a seeded stream, so a failing mix can be replayed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// A multiple of 1/64 in [-max, max]: exact in f32 and in JSON.
    fn offset(&mut self, max: f32) -> f32 {
        let steps = (max * 64.0) as i64;
        (self.below((2 * steps + 1) as usize) as i64 - steps) as f32 / 64.0
    }
}

/// Starts the server; returns it and its address, read from its log.
fn start(dir: &Path) -> (Child, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_frusta-server"))
        .args(["--addr", "127.0.0.1:0", "--data-dir"])
        .arg(dir.join("data"))
        .arg("--scenes-dir")
        .arg(dir.join("no-bundled-scenes"))
        .env("RUST_LOG", "info")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start frusta-server");
    let stdout = child.stdout.take().expect("stdout");
    let mut lines = BufReader::new(stdout).lines();
    let addr = loop {
        let line = lines
            .next()
            .expect("the server exited before listening")
            .expect("log line");
        if let Some(rest) = line.split("addr=").nth(1) {
            break rest.split_whitespace().next().expect("address").to_owned();
        }
    };
    // Keep draining the log so the server never blocks on a full pipe.
    std::thread::spawn(move || lines.for_each(drop));
    (child, addr)
}

fn client(addr: &str) -> Client {
    let config = Config {
        timeout: Some(Duration::from_secs(20)),
        ..Config::default()
    };
    Client::new(&format!("http://{addr}"), config).expect("client")
}

/// A write's outcome: answered with success, refused (a bug: every write
/// here is valid), or cut off by the stop.
enum Sent {
    Done,
    Refused(String),
    Cut,
}

fn http(result: Result<Answer, Error>) -> Sent {
    match result {
        Ok(a) if a.is_success() => Sent::Done,
        Ok(a) => Sent::Refused(format!(
            "{}: {}",
            a.status,
            String::from_utf8_lossy(&a.body)
        )),
        Err(_) => Sent::Cut,
    }
}

/// Moves the door over a stream, acknowledged by `objects_updated`.
fn stream_move(client: &Client, id: &str, yz: [f32; 2]) -> Sent {
    let Ok(mut stream) = client.stream(id) else {
        return Sent::Cut;
    };
    let update = StreamUpdate {
        objects: Some(vec![ObjectMove {
            object: "door".into(),
            patch: ObjectPatch {
                translation: Some([0.0, yz[0], yz[1]]),
                ..ObjectPatch::default()
            },
        }]),
        ..StreamUpdate::default()
    };
    if stream.send(&update).is_err() {
        return Sent::Cut;
    }
    let sent = match stream.read() {
        Ok(Received::ObjectsUpdated(_)) => Sent::Done,
        // The plain stop closes streams (1001) with an update in flight.
        Ok(Received::Closed { .. }) => Sent::Cut,
        Ok(Received::Error(problem)) => Sent::Refused(problem.to_string()),
        Ok(other) => Sent::Refused(format!("{other:?}")),
        Err(_) => Sent::Cut,
    };
    let _ = stream.close();
    sent
}

/// One random write: picks it, records it as in flight, sends it.
fn write_one(rng: &mut Rng, ledger: &Mutex<Ledger>, client: &Client) -> Sent {
    let base = "/v1/scenes";
    let (id, before) = {
        let mut l = ledger.lock().expect("ledger");
        let live: Vec<(String, Model)> = l
            .confirmed
            .iter()
            .filter(|(_, m)| **m != Model::Absent)
            .map(|(id, m)| (id.clone(), m.clone()))
            .collect();
        if live.len() < 3 || rng.below(8) == 0 {
            l.next_id += 1;
            (format!("s{}", l.next_id), Model::Absent)
        } else {
            live[rng.below(live.len())].clone()
        }
    };
    let record = |after: &Model| {
        ledger.lock().expect("ledger").in_flight = Some((id.clone(), after.clone()));
    };
    let (after, sent) = match before {
        Model::Absent if rng.below(4) == 0 => {
            let after = Model::Mesh;
            record(&after);
            let url = format!("{base}?id={id}&object=mesh");
            let sent = http(client.post(&url, "model/obj", OBJ.as_bytes()));
            (after, sent)
        }
        Model::Absent => {
            let after = Model::Room(Room::new());
            record(&after);
            let url = format!("{base}?id={id}");
            let sent = http(client.post(&url, "application/json", ROOM.as_bytes()));
            (after, sent)
        }
        Model::Mesh => {
            record(&Model::Absent);
            (Model::Absent, http(client.delete(&format!("{base}/{id}"))))
        }
        Model::Room(room) => {
            let mut next = room.clone();
            let object = |name: &str| format!("{base}/{id}/objects/{name}");
            let json = |url: String, body: Value| {
                client.patch(&url, "application/json", body.to_string().as_bytes())
            };
            match rng.below(7) {
                0 => {
                    next.door_yz = [rng.offset(0.5), rng.offset(0.5)];
                    record(&Model::Room(next.clone()));
                    let t = [0.0, next.door_yz[0], next.door_yz[1]];
                    let sent = http(json(object("door"), serde_json::json!({"translation": t})));
                    (Model::Room(next), sent)
                }
                1 => {
                    let half = rng.offset(1.5) / 2.0;
                    next.panel_rotation = [0.0, half.sin(), 0.0, half.cos()];
                    record(&Model::Room(next.clone()));
                    let body = serde_json::json!({"rotation": next.panel_rotation});
                    (Model::Room(next), http(json(object("panel"), body)))
                }
                2 => {
                    next.door_dx = rng.offset(1.0);
                    record(&Model::Room(next.clone()));
                    let body = serde_json::json!({"vertices": Room::door_vertices(next.door_dx)});
                    (Model::Room(next), http(json(object("door"), body)))
                }
                3 => {
                    next.door_dx = rng.offset(1.0);
                    record(&Model::Room(next.clone()));
                    let bytes: Vec<u8> = Room::door_vertices(next.door_dx)
                        .iter()
                        .flatten()
                        .flat_map(|c| c.to_le_bytes())
                        .collect();
                    let sent =
                        http(client.patch(&object("door"), "application/octet-stream", &bytes));
                    (Model::Room(next), sent)
                }
                4 => {
                    let name = format!("m{}", next.added_materials.len());
                    next.added_materials.push(name.clone());
                    record(&Model::Room(next.clone()));
                    let body = serde_json::json!({"materials": {name: {"absorption": 0.3}}});
                    let url = format!("{base}/{id}/materials");
                    (Model::Room(next), http(json(url, body)))
                }
                5 => {
                    next.door_yz = [rng.offset(0.5), rng.offset(0.5)];
                    record(&Model::Room(next.clone()));
                    let sent = stream_move(client, &id, next.door_yz);
                    (Model::Room(next), sent)
                }
                _ => {
                    record(&Model::Absent);
                    (Model::Absent, http(client.delete(&format!("{base}/{id}"))))
                }
            }
        }
    };
    if let Sent::Done = sent {
        let mut l = ledger.lock().expect("ledger");
        l.confirmed.insert(id, after);
        l.in_flight = None;
    }
    sent
}

/// Reads back what the server holds for `id`.
fn observe(client: &Client, id: &str) -> Model {
    let base = format!("/v1/scenes/{id}");
    let response = client.get(&base).expect("GET scene");
    if response.status == 404 {
        return Model::Absent;
    }
    assert_eq!(response.status, 200, "GET {id}");
    let detail: Value = serde_json::from_slice(&response.body).expect("JSON");
    let objects = detail["objects"].as_array().expect("objects");
    if objects.len() == 1 {
        return Model::Mesh;
    }
    let floats = |v: &Value| -> Vec<f32> {
        v.as_array()
            .expect("array")
            .iter()
            .map(|x| x.as_f64().expect("number") as f32)
            .collect()
    };
    let door = floats(&objects[1]["translation"]);
    let rotation = floats(&objects[2]["rotation"]);
    let materials: Vec<String> = detail["materials"]
        .as_array()
        .expect("materials")
        .iter()
        .map(|m| m.as_str().expect("name").to_owned())
        .filter(|m| m.starts_with('m'))
        .collect();
    // The door's x from a ray along +x through its middle.
    let ray = serde_json::json!({"rays": [{"origin": [0.5, 1.5 + door[1], 1.0 + door[2]], "direction": [1, 0, 0]}]});
    let hit = client
        .post(
            &format!("{base}/rays"),
            "application/json",
            ray.to_string().as_bytes(),
        )
        .expect("rays");
    let hits: Value = serde_json::from_slice(&hit.body).expect("JSON");
    let hit = &hits["hits"][0];
    assert_eq!(hit["object_name"], "door", "{id}: the ray misses the door");
    let t = hit["t"].as_f64().expect("t") as f32;
    Model::Room(Room {
        door_yz: [door[1], door[2]],
        door_dx: t - 2.5,
        panel_rotation: [rotation[0], rotation[1], rotation[2], rotation[3]],
        added_materials: materials,
    })
}

/// Equal up to float noise (a ray's `t`, a renormalised quaternion).
fn same(a: &Model, b: &Model) -> bool {
    let close = |x: &[f32], y: &[f32]| x.iter().zip(y).all(|(x, y)| (x - y).abs() < 1e-4);
    match (a, b) {
        (Model::Room(a), Model::Room(b)) => {
            close(&a.door_yz, &b.door_yz)
                && close(&[a.door_dx], &[b.door_dx])
                && close(&a.panel_rotation, &b.panel_rotation)
                && a.added_materials == b.added_materials
        }
        (a, b) => a == b,
    }
}

/// Checks every scene against the ledger and settles the write in flight
/// to what the server kept.
fn verify(ledger: &mut Ledger, client: &Client, round: usize) {
    let in_flight = ledger.in_flight.take();
    let mut ids: Vec<String> = ledger.confirmed.keys().cloned().collect();
    ids.extend(in_flight.iter().map(|(id, _)| id.clone()));
    for id in ids {
        let expected = ledger.confirmed.get(&id).cloned().unwrap_or(Model::Absent);
        let seen = observe(client, &id);
        if same(&seen, &expected) {
            continue;
        }
        match &in_flight {
            Some((flying, after)) if *flying == id && same(&seen, after) => {
                ledger.confirmed.insert(id, after.clone());
            }
            _ => panic!(
                "round {round}, scene {id}: the server holds {seen:?}, acknowledged {expected:?} (in flight: {in_flight:?})"
            ),
        }
    }
}

#[test]
fn every_acknowledged_write_survives_kill_9_and_restart() {
    let dir = std::env::temp_dir().join(format!("frusta-crash-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let ledger = Arc::new(Mutex::new(Ledger::default()));
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    // Nine kill -9 rounds, then a plain stop (SIGTERM), each checked on
    // the next start.
    let rounds = 10;
    for round in 0..rounds {
        let (mut server, addr) = start(&dir);
        verify(&mut ledger.lock().expect("ledger"), &client(&addr), round);
        let acknowledged = Arc::new(AtomicUsize::new(0));
        let stop = Arc::new(AtomicBool::new(false));
        let mut writer_rng = Rng(rng.next() | 1);
        let writer = {
            let (ledger, acknowledged, stop, addr) = (
                ledger.clone(),
                acknowledged.clone(),
                stop.clone(),
                addr.clone(),
            );
            std::thread::spawn(move || -> Option<String> {
                let client = client(&addr);
                while !stop.load(Ordering::Relaxed) {
                    match write_one(&mut writer_rng, &ledger, &client) {
                        Sent::Done => acknowledged.fetch_add(1, Ordering::Relaxed),
                        Sent::Refused(why) => return Some(why),
                        Sent::Cut => return None,
                    };
                }
                None
            })
        };
        let target = 30 + rng.below(150);
        let started = Instant::now();
        while acknowledged.load(Ordering::Relaxed) < target && !writer.is_finished() {
            assert!(
                started.elapsed() < Duration::from_secs(120),
                "the server stopped answering"
            );
            std::thread::sleep(Duration::from_millis(2));
        }
        assert!(
            !writer.is_finished(),
            "round {round}: the writer stopped before the server did: {:?}",
            writer.join()
        );
        if round + 1 < rounds {
            server.kill().expect("kill -9");
        } else {
            let terminated = Command::new("kill")
                .args(["-TERM", &server.id().to_string()])
                .status()
                .expect("kill -TERM");
            assert!(terminated.success());
            stop.store(true, Ordering::Relaxed);
        }
        let exit = server.wait().expect("reap");
        stop.store(true, Ordering::Relaxed);
        if let Some(why) = writer.join().expect("writer") {
            panic!("round {round}: a valid write was refused: {why}");
        }
        if round + 1 == rounds {
            assert!(exit.success(), "a plain stop exits cleanly: {exit}");
        }
    }
    let (mut server, addr) = start(&dir);
    let mut ledger = ledger.lock().expect("ledger");
    verify(&mut ledger, &client(&addr), rounds);
    let kinds: Vec<&Model> = ledger.confirmed.values().collect();
    assert!(
        kinds
            .iter()
            .any(|m| matches!(m, Model::Room(r) if !r.added_materials.is_empty())),
        "the mix never edited materials: {kinds:?}"
    );
    server.kill().expect("stop");
    server.wait().expect("reap");
    let _ = std::fs::remove_dir_all(&dir);
}
