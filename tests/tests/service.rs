//! The service end to end: the real server on a loopback port, and
//! `frusta-client`, the client every Rust caller uses.

use std::time::{Duration, Instant};

use frusta_client::api::impulse_responses::Point;
use frusta_client::api::objects::{EditAction, ObjectPatch};
use frusta_client::api::stream::{ObjectMove, StreamAnswer, StreamUpdate};
use frusta_client::{Received, Stream};
use frusta_engine::acoustics::signal::ImpulseResponse;
use frusta_engine::acoustics::SimulationOptions;
use frusta_tests::*;
use serde_json::{json, Value};

const IR: &str = r#"{"sources": [{"position": [2, 1.5, 1.2]}], "listeners": [{"position": [7, 1.5, 1.2]}], "max_order": 2, "sample_rate": 16000}"#;

fn paths(answer: &Value) -> Vec<f64> {
    answer["responses"][0]["paths"]
        .as_array()
        .expect("paths")
        .iter()
        .map(|p| p["distance_m"].as_f64().expect("distance"))
        .collect()
}

#[test]
fn upload_ir_patch_ir_changes() {
    let data = DataDir::new("patch");
    let server = Server::start(&data);
    let (status, _, created) = server.post("/v1/scenes", BOX_DOC);
    assert_eq!(status, 201, "{created}");
    let id = created["id"].as_str().expect("id").to_owned();
    assert_eq!(id, "box-with-panel");
    let ir_url = format!("/v1/scenes/{id}/impulse-responses");
    let (status, _, before) = server.post(&ir_url, IR);
    assert_eq!(status, 200, "{before}");
    // The panel stands between source and listener: no direct path.
    assert!(paths(&before)[0] > 5.0 + 1e-6, "{:?}", paths(&before));
    assert_eq!(before["revision"], 0);
    let (status, _, moved) = server.patch(
        &format!("/v1/scenes/{id}/objects/panel"),
        r#"{"translation": [0, 3, 0]}"#,
    );
    assert_eq!(status, 200, "{moved}");
    assert_eq!(moved["action"], "transform");
    let (_, _, after) = server.post(&ir_url, IR);
    assert_eq!(after["revision"], 1);
    assert!(
        (paths(&after)[0] - 5.0).abs() < 1e-6,
        "the direct path is open"
    );
    let (status, _, _) = server.delete(&format!("/v1/scenes/{id}"));
    assert_eq!(status, 204);
    assert_eq!(server.post(&ir_url, IR).0, 404);
}

#[test]
fn scenes_and_edits_survive_a_restart() {
    let data = DataDir::new("restart");
    let server = Server::start(&data);
    let (status, _, _) = server.post("/v1/scenes?id=kept", BOX_DOC);
    assert_eq!(status, 201);
    let vertices = r#"{"vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, 2.5], [4, 1, 2.5]], "translation": [0.5, 0, 0]}"#;
    assert_eq!(
        server.patch("/v1/scenes/kept/objects/panel", vertices).0,
        200
    );
    let edited_ir = server.post("/v1/scenes/kept/impulse-responses", IR).2;
    assert_eq!(server.delete("/v1/scenes/l-room").0, 204);
    server.stop();

    let server = Server::start(&data);
    let (status, _, detail) = server.get("/v1/scenes/kept");
    assert_eq!(status, 200, "{detail}");
    assert_eq!(detail["objects"][1]["translation"], json!([0.5, 0.0, 0.0]));
    let restored_ir = server.post("/v1/scenes/kept/impulse-responses", IR).2;
    assert_eq!(paths(&restored_ir), paths(&edited_ir));
    let (_, _, list) = server.get("/v1/scenes");
    let ids: Vec<&str> = list["scenes"]
        .as_array()
        .expect("scenes")
        .iter()
        .filter_map(|s| s["id"].as_str())
        .collect();
    assert_eq!(
        ids,
        ["kept", "shoebox"],
        "a deleted bundled scene stays deleted"
    );
}

#[test]
fn every_bad_input_is_a_4xx_problem() {
    let data = DataDir::new("bad");
    let server = Server::start(&data);
    let ir = "/v1/scenes/shoebox/impulse-responses".to_owned();
    let p = r#"[{"position": [2, 3, 1.5]}]"#;
    let cases: Vec<(String, String, u16)> = vec![
        (ir.clone(), "{\"sources\": [".into(), 400),
        (ir.clone(), format!(r#"{{"sources": {p}, "listeners": [{{"position": [1e39, 1, 1]}}]}}"#), 422),
        (ir.clone(), format!(r#"{{"sources": {p}, "listeners": {p}, "max_order": 1000}}"#), 422),
        (ir.clone(), format!(r#"{{"sources": {p}, "listeners": {p}, "sampling": 1000}}"#), 422),
        ("/v1/scenes/nowhere/impulse-responses".into(), IR.into(), 404),
        (
            "/v1/scenes".into(),
            r#"{"objects": [{"name": "t", "material": "concrete", "mesh": {"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 3]]}}]}"#.into(),
            422,
        ),
        (
            "/v1/scenes".into(),
            r#"{"objects": [{"name": "t", "material": "concrete", "mesh": {"vertices": [[0,0,0],[1,0,0],[0,1e39,0]], "triangles": [[0, 1, 2]]}}]}"#.into(),
            422,
        ),
        ("/v1/scenes/shoebox/rays".into(), r#"{"rays": [{"origin": [0, 0, 0], "direction": [0, 0, 0]}]}"#.into(), 422),
        ("/v1/scenes/shoebox/occlusion".into(), r#"{"pairs": [{"from": [0, 0, 0]}]}"#.into(), 422),
    ];
    for (url, body, expected) in cases {
        let (status, content_type, problem) = server.post(&url, &body);
        assert_eq!(status, expected, "{url} {body}: {problem}");
        assert_eq!(content_type, "application/problem+json", "{url} {body}");
        assert_eq!(problem["status"], expected);
        assert!(problem["type"]
            .as_str()
            .is_some_and(|t| t.starts_with("urn:frusta:problem:")));
        assert!(
            problem["detail"].as_str().is_some_and(|d| d.len() > 10),
            "{problem}"
        );
    }
    // A plain GET on a stream is told what the route wants.
    let (status, content_type, problem) = server.get("/v1/scenes/shoebox/stream");
    assert_eq!(status, 400, "{problem}");
    assert_eq!(content_type, "application/problem+json");
    assert_eq!(problem["type"], "urn:frusta:problem:bad-upgrade");
    let (status, _, problem) = server.patch(
        "/v1/scenes/shoebox/objects/room",
        r#"{"vertices": [[0, 0, 0]]}"#,
    );
    assert_eq!(status, 422, "{problem}");
    // Nothing was lost or changed on the way.
    let (status, _, shoebox) = server.get("/v1/scenes/shoebox");
    assert_eq!(status, 200);
    assert_eq!(shoebox["revision"], 0);
    assert_eq!(server.get("/healthz").0, 200);
}

fn point(position: [f32; 3]) -> Option<Vec<Point>> {
    Some(vec![Point { position }])
}

fn options(options: Value) -> Option<SimulationOptions> {
    Some(serde_json::from_value(options).expect("options"))
}

fn update(seq: u64, listener: [f32; 3]) -> StreamUpdate {
    StreamUpdate {
        seq: Some(seq),
        sources: point([2.0, 3.0, 1.5]),
        listeners: point(listener),
        options: options(json!({"max_order": 3, "sample_rate": 16000})),
        ..Default::default()
    }
}

fn move_panel(translation: [f32; 3]) -> Option<Vec<ObjectMove>> {
    let patch = ObjectPatch {
        translation: Some(translation),
        ..Default::default()
    };
    Some(vec![ObjectMove {
        object: "panel".into(),
        patch,
    }])
}

/// The next answer and its samples.
fn read_answer(stream: &mut Stream) -> (StreamAnswer, ImpulseResponse) {
    match stream.read().expect("read") {
        Received::ImpulseResponse { answer, samples } => (*answer, samples),
        other => panic!("expected an impulse response, got {other:?}"),
    }
}

/// Reads until the server's Close; its code.
fn close_code(stream: &mut Stream) -> Option<u16> {
    loop {
        match stream.read() {
            Ok(Received::Closed { code, .. }) => break code,
            Ok(_) => {}
            Err(e) => panic!("no close frame: {e}"),
        }
    }
}

#[test]
fn stream_with_a_moving_listener() {
    let data = DataDir::new("stream");
    let server = Server::start(&data);
    let mut stream = server.client().stream("shoebox").expect("connect");
    let mut last_direct = 0.0;
    for step in 0..6u64 {
        let listener = [5.0 + 0.5 * step as f32, 3.0, 1.5];
        stream.send(&update(step, listener)).expect("send");
        let (answer, samples) = read_answer(&mut stream);
        assert_eq!(answer.seq, Some(step));
        assert_eq!(answer.revision, 0);
        let direct = answer.pair.paths[0].distance_m;
        assert!(
            (direct - f64::from(listener[0] - 2.0)).abs() < 1e-5,
            "{direct}"
        );
        assert!(direct > last_direct);
        last_direct = direct;
        assert_eq!(
            answer.pair.stats.beams_reused,
            step > 0,
            "only the listener moved"
        );
        assert_eq!(samples.channels[0].len(), answer.pair.frames);
        assert!(samples.channels[0].iter().any(|&s| s != 0.0));
    }
    // A bad update is answered with a problem and the stream goes on.
    let no_listener = StreamUpdate {
        listeners: Some(Vec::new()),
        ..Default::default()
    };
    stream.send(&no_listener).expect("send");
    match stream.read().expect("read") {
        Received::Error(problem) => {
            assert_eq!(
                problem.kind, "urn:frusta:problem:invalid-input",
                "{problem}"
            );
            assert_eq!(problem.status, 422);
        }
        other => panic!("expected a problem, got {other:?}"),
    }
    stream.send(&update(99, [6.0, 2.0, 1.5])).expect("send");
    let (exact, _) = read_answer(&mut stream);
    assert_eq!(exact.seq, Some(99));
    assert_eq!(exact.pair.stats.lod_error_m, 0.0);
    // Levels of detail: at 8 m the shoebox is one rectangle (its one
    // node's error is about 6.7 m), traced afresh; the stream keeps the
    // bound, and the frusta while only the listener moves (the server
    // keeps the simplification).
    let lod = StreamUpdate {
        lod_error_m: Some(8.0),
        ..update(100, [6.0, 2.0, 1.5])
    };
    stream.send(&lod).expect("send");
    let (coarse, _) = read_answer(&mut stream);
    assert_eq!(coarse.pair.stats.lod_error_m, 8.0);
    assert!(coarse.pair.paths.len() < exact.pair.paths.len());
    assert!(!coarse.pair.stats.beams_reused);
    stream.send(&update(101, [6.2, 2.0, 1.5])).expect("send");
    let (moved, _) = read_answer(&mut stream);
    assert_eq!(moved.pair.stats.lod_error_m, 8.0);
    assert!(moved.pair.stats.beams_reused);
    // The client closes; the server answers with its Close (RFC 6455
    // 5.5.1) rather than dropping the connection.
    stream
        .close()
        .expect("the server completes the close handshake");
}

#[test]
fn streams_see_each_others_edits() {
    let data = DataDir::new("shared");
    let server = Server::start(&data);
    assert_eq!(server.post("/v1/scenes?id=box", BOX_DOC).0, 201);
    let client = server.client();
    let mut watcher = client.stream("box").expect("connect");
    let mut mover = client.stream("box").expect("connect");
    let behind_panel = StreamUpdate {
        seq: Some(1),
        sources: point([2.0, 1.5, 1.2]),
        listeners: point([7.0, 1.5, 1.2]),
        ..Default::default()
    };
    watcher.send(&behind_panel).expect("send");
    let (before, _) = read_answer(&mut watcher);
    assert_eq!(before.revision, 0);
    assert!(
        before.pair.paths[0].distance_m > 5.0 + 1e-6,
        "the panel blocks"
    );
    let edit = StreamUpdate {
        seq: Some(5),
        objects: move_panel([0.0, 3.0, 0.0]),
        ..behind_panel
    };
    mover.send(&edit).expect("send");
    let (moved, _) = read_answer(&mut mover);
    assert_eq!(moved.revision, 1);
    assert_eq!(moved.objects[0].action, EditAction::Transform);
    // The watcher is told without asking, on the same revision.
    let (seen, _) = read_answer(&mut watcher);
    assert_eq!(seen.revision, 1);
    assert_eq!(
        seen.pair.paths[0].distance_m,
        moved.pair.paths[0].distance_m
    );
}

#[test]
fn a_client_leaving_mid_stream_leaves_the_server_healthy() {
    let data = DataDir::new("leave");
    let server = Server::start(&data);
    for _ in 0..3 {
        let mut stream = server.client().stream("l-room").expect("connect");
        stream.send(&update(1, [3.0, 3.0, 1.5])).expect("send");
        // Gone before the answer: no close handshake.
        drop(stream);
    }
    assert_eq!(server.get("/healthz").0, 200);
    assert_eq!(
        server.post("/v1/scenes/shoebox/impulse-responses", IR).0,
        200
    );
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let metrics = server.get("/metrics").2;
        let text = metrics.as_str().unwrap_or_default().to_owned();
        if text.contains("frusta_streams 0") {
            break;
        }
        assert!(Instant::now() < deadline, "streams never closed:\n{text}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn shutdown_closes_streams_with_going_away() {
    let data = DataDir::new("shutdown");
    let server = Server::start(&data);
    let mut stream = server.client().stream("shoebox").expect("connect");
    stream.send(&update(1, [6.0, 3.0, 1.5])).expect("send");
    read_answer(&mut stream);
    let stopper = std::thread::spawn(move || server.stop());
    assert_eq!(close_code(&mut stream), Some(1001));
    stopper.join().expect("the server stopped");
}

#[test]
fn updates_faster_than_the_engine_coalesce_newest_first() {
    let data = DataDir::new("coalesce");
    let server = Server::start(&data);
    let mut stream = server.client().stream("l-room").expect("connect");
    // Moving the source retraces every time: far slower than sending.
    let source = |seq: u64| [2.0 + 0.05 * seq as f32, 3.0, 1.5];
    for seq in 0..20u64 {
        let update = StreamUpdate {
            seq: Some(seq),
            sources: point(source(seq)),
            listeners: point([4.0, 6.0, 1.5]),
            options: options(json!({"max_order": 5, "sampling": 16, "sample_rate": 8000})),
            ..Default::default()
        };
        stream.send(&update).expect("send");
    }
    let mut answers = 0;
    let last = loop {
        let (answer, _) = read_answer(&mut stream);
        answers += 1;
        if answer.seq == Some(19) {
            break answer;
        }
    };
    assert!(
        answers < 20,
        "{answers} answers: updates were not coalesced"
    );
    let expected = ((4.0 - f64::from(source(19)[0])).powi(2) + 9.0f64).sqrt();
    let direct = last.pair.paths[0].distance_m;
    assert!(
        (direct - expected).abs() < 1e-5,
        "the newest source wins: {direct} vs {expected}"
    );
}

#[test]
fn object_moves_before_any_listener_are_applied_and_stored() {
    let data = DataDir::new("objects-only");
    let server = Server::start(&data);
    assert_eq!(server.post("/v1/scenes?id=box", BOX_DOC).0, 201);
    let mut stream = server.client().stream("box").expect("connect");
    let moves = StreamUpdate {
        seq: Some(3),
        objects: move_panel([0.0, 2.0, 0.0]),
        ..Default::default()
    };
    stream.send(&moves).expect("send");
    match stream.read().expect("read") {
        Received::ObjectsUpdated(updated) => {
            assert_eq!(updated.seq, Some(3));
            assert_eq!(updated.revision, 1);
        }
        other => panic!("expected objects_updated, got {other:?}"),
    }
    let (_, _, detail) = server.get("/v1/scenes/box");
    assert_eq!(detail["objects"][1]["translation"], json!([0.0, 2.0, 0.0]));
}

#[test]
fn streams_are_capped_and_a_deleted_scene_closes_its_streams() {
    let data = DataDir::new("cap");
    let mut config = data.config();
    config.limits.max_streams = 1;
    let server = Server::start_with(config);
    assert_eq!(server.post("/v1/scenes?id=box", BOX_DOC).0, 201);
    let client = server.client();
    let mut stream = client.stream("box").expect("connect");
    stream.send(&update(1, [6.0, 3.0, 1.5])).expect("send");
    read_answer(&mut stream);
    match client.stream("box") {
        Err(frusta_client::Error::Status(answer)) => assert_eq!(answer.status, 503),
        other => panic!("a second stream was accepted: {:?}", other.map(|_| ())),
    }
    assert_eq!(server.delete("/v1/scenes/box").0, 204);
    match stream.read().expect("read") {
        Received::Error(problem) => {
            assert_eq!(
                problem.kind, "urn:frusta:problem:unknown-scene",
                "{problem}"
            )
        }
        other => panic!("expected a problem, got {other:?}"),
    }
    assert_eq!(close_code(&mut stream), Some(1000));
}

#[test]
fn half_sent_requests_are_cut_off_and_cannot_take_every_connection() {
    use std::io::{Read, Write};
    let data = DataDir::new("slow-headers");
    let mut config = data.config();
    config.limits.header_timeout_s = 1;
    config.limits.max_connections = 4;
    let server = Server::start_with(config);
    let address = server.addr();
    // Every connection the server takes, held by a client that never
    // finishes its headers.
    let stalled: Vec<std::net::TcpStream> = (0..4)
        .map(|_| {
            let mut s = std::net::TcpStream::connect(address).expect("connect");
            s.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
                .expect("write");
            s
        })
        .collect();
    // The server closes them once the header timeout passes...
    for mut s in stalled {
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        let mut buf = [0u8; 256];
        // Whatever the server writes, then the end of the stream.
        let end = loop {
            match s.read(&mut buf) {
                Ok(0) => break None,
                Ok(_) => continue,
                Err(e) => break Some(e.kind()),
            }
        };
        let waited = matches!(
            end,
            Some(std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut)
        );
        assert!(!waited, "a half-sent request was kept open for 10 s");
    }
    // ... so a well-behaved client is served again.
    let (status, _, _) = server.get("/healthz");
    assert_eq!(status, 200);
}

#[test]
fn a_stream_whose_client_leaves_gives_its_worker_back() {
    let data = DataDir::new("cancel");
    let server = Server::start(&data);
    let hall = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/hall-10k.json"),
    )
    .expect("hall");
    assert_eq!(server.post("/v1/scenes?id=hall", &hall).0, 201);
    // One stream per simulation worker, each starting seconds of work
    // (conservative cells, order 4, in the hall), then gone.
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get().min(4));
    let expensive = StreamUpdate {
        sources: point([3.0, 12.0, 2.5]),
        listeners: point([22.0, 9.0, 1.7]),
        options: options(
            json!({"max_order": 4, "sampling": 8, "cells": "conservative", "energy_threshold": 0}),
        ),
        ..Default::default()
    };
    for _ in 0..workers {
        let mut stream = server.client().stream("hall").expect("connect");
        stream.send(&expensive).expect("send");
        std::thread::sleep(Duration::from_millis(300));
        drop(stream);
    }
    // Their work is cancelled: a small request is answered at once, not
    // after the hall traces end.
    let start = Instant::now();
    assert_eq!(
        server.post("/v1/scenes/shoebox/impulse-responses", IR).0,
        200
    );
    assert!(
        start.elapsed() < Duration::from_secs(4),
        "waited {:?}",
        start.elapsed()
    );
}
