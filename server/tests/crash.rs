//! `kill -9` in the middle of writes loses nothing the server acknowledged
//! and corrupts nothing: the real binary, killed and restarted on the same
//! data directory.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const DOC: &str = r#"{"materials": {"walls": {"absorption": 0.2}}, "objects": [
  {"name": "room", "material": "walls", "mesh": {"box_room": {"min": [0, 0, 0], "max": [6, 5, 3], "subdivisions": 8}}},
  {"name": "door", "material": "walls", "dynamic": true,
   "mesh": {"vertices": [[3, 1, 0], [3, 2, 0], [3, 2, 2], [3, 1, 2]], "triangles": [[0, 1, 2], [0, 2, 3]]}}]}"#;

/// Starts the server; returns it and its address, read from its log.
fn start(dir: &std::path::Path) -> (Child, String) {
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
    (child, format!("http://{addr}"))
}

/// One uploaded scene: the door position the server confirmed, and the one
/// sent after it, if any (equal to `confirmed` once that move is answered).
#[derive(Clone)]
struct Door {
    scene: String,
    confirmed: f64,
    in_flight: f64,
}

fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_global(Some(Duration::from_secs(20)))
        .build()
        .into()
}

#[test]
fn kill_9_mid_write_loses_nothing_acknowledged() {
    let dir = std::env::temp_dir().join(format!("frusta-crash-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (mut server, base) = start(&dir);

    // Uploads and moves, as fast as one client can. Each acknowledged upload
    // is recorded with the door position the server confirmed and the one
    // in flight: the kill may land after the server stored and answered a
    // move but before this client read the answer, so the store may hold
    // either of the two, and nothing else.
    let acknowledged = Arc::new(Mutex::new(Vec::<Door>::new()));
    let stop = Arc::new(AtomicBool::new(false));
    let writer = {
        let (acknowledged, stop, base) = (acknowledged.clone(), stop.clone(), base.clone());
        std::thread::spawn(move || {
            let agent = agent();
            for i in 0u32.. {
                if stop.load(Ordering::Relaxed) {
                    return;
                }
                let id = format!("s{i}");
                let created = agent
                    .post(&format!("{base}/v1/scenes?id={id}"))
                    .header("content-type", "application/json")
                    .send(DOC);
                match created {
                    Ok(r) if r.status() == 201 => {}
                    _ => return,
                }
                let y = 0.01 * f64::from(i % 300);
                acknowledged.lock().expect("lock").push(Door {
                    scene: id.clone(),
                    confirmed: 0.0,
                    in_flight: y,
                });
                let moved = agent
                    .patch(&format!("{base}/v1/scenes/{id}/objects/door"))
                    .header("content-type", "application/json")
                    .send(format!(r#"{{"translation": [0, {y}, 0]}}"#));
                match moved {
                    Ok(r) if r.status() == 200 => {}
                    _ => return,
                }
                acknowledged
                    .lock()
                    .expect("lock")
                    .last_mut()
                    .expect("entry")
                    .confirmed = y;
            }
        })
    };
    let started = Instant::now();
    while acknowledged.lock().expect("lock").len() < 25 {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the server stopped answering"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    server.kill().expect("kill -9");
    server.wait().expect("reap");
    stop.store(true, Ordering::Relaxed);
    writer.join().expect("writer");

    let (mut server, base) = start(&dir);
    let agent = agent();
    let acknowledged = acknowledged.lock().expect("lock").clone();
    for door in &acknowledged {
        let id = &door.scene;
        let mut response = agent
            .get(&format!("{base}/v1/scenes/{id}"))
            .call()
            .expect("GET");
        assert_eq!(response.status(), 200, "acknowledged scene {id} was lost");
        let detail: serde_json::Value =
            serde_json::from_str(&response.body_mut().read_to_string().expect("body"))
                .expect("JSON");
        let stored = detail["objects"][1]["translation"][1].as_f64().expect("y");
        assert!(
            (stored - door.confirmed).abs() < 1e-6 || (stored - door.in_flight).abs() < 1e-6,
            "{id}: door at {stored}, acknowledged {} (in flight {})",
            door.confirmed,
            door.in_flight
        );
    }
    // The store still takes writes.
    let created = agent
        .post(&format!("{base}/v1/scenes?id=after"))
        .header("content-type", "application/json")
        .send(DOC)
        .expect("POST");
    assert_eq!(created.status(), 201);
    server.kill().expect("stop");
    server.wait().expect("reap");
    let _ = std::fs::remove_dir_all(&dir);
}
