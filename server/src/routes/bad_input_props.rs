//! Property test of every JSON route against bad input: valid requests
//! with a few of their values replaced by adversarial ones (wrong types,
//! non-finite and out-of-range numbers, missing and unknown keys, long
//! arrays), or taken apart. The service must answer each with a success or
//! a 4xx problem document (a compute limit included), never a 5xx or a
//! panic; a refused request must leave the scene as it was (its document
//! and revision), and what the accepted ones stored must come back after a
//! restart.

use axum::http::StatusCode;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use serde_json::{json, Value};

use crate::routes::test_support::*;

/// A route, and a request it must accept.
struct Seed {
    method: &'static str,
    uri: &'static str,
    body: Value,
}

fn seeds() -> Vec<Seed> {
    let post = |uri, body| Seed {
        method: "POST",
        uri,
        body,
    };
    let patch = |uri, body| Seed {
        method: "PATCH",
        uri,
        body,
    };
    vec![
        post(
            "/v1/scenes",
            serde_json::from_str(BOX_DOC).expect("the shoebox document"),
        ),
        post(
            "/v1/scenes/box/impulse-responses",
            json!({"sources": [{"position": [2, 3, 1.5]}], "listeners": [{"position": [7, 2, 1.2]}],
                   "max_order": 2, "sampling": 4, "tail": {"rays": 64, "max_length_s": 0.2}, "lod_error_m": 0.5}),
        ),
        post(
            "/v1/scenes/box/rays",
            json!({"mode": "closest", "rays": [{"origin": [2, 3, 1.5], "direction": [1, 0, 0], "max_distance": 9}],
                   "lod": {"max_error_m": 0.2, "cone_angle": 0.02}}),
        ),
        post(
            "/v1/scenes/box/occlusion",
            json!({"pairs": [{"from": [2, 1.5, 1], "to": [6, 1.5, 1]}]}),
        ),
        post(
            "/v1/scenes/box/visibility",
            json!({"light": {"position": [2, 1.5, 1.2]}, "points": [[6, 1, 1], [6, 5, 1]],
                   "method": "selective", "samples": 4}),
        ),
        post(
            "/v1/scenes/box/shadows",
            json!({"camera": {"position": [1, 1, 2.5], "look_at": [6, 4, 0], "width": 16, "height": 12},
                   "light": {"position": [5, 3, 2.8]}}),
        ),
        post(
            "/v1/scenes/box/collisions",
            json!({"kind": "continuous", "pairs": [["room", "panel"]],
                   "moves": [{"object": "panel", "translation": [1, 0, 0]}], "max_contacts": 10}),
        ),
        patch(
            "/v1/scenes/box/objects/panel",
            json!({"translation": [0.5, 0, 0], "rotation": [0, 0, 0, 1]}),
        ),
        patch(
            "/v1/scenes/box/materials",
            json!({"materials": {"walls": {"absorption": 0.2, "scattering": 0.1}}}),
        ),
    ]
}

/// Values that have broken parsers and handlers elsewhere.
fn adversarial() -> Vec<Value> {
    vec![
        Value::Null,
        json!(true),
        json!(-1),
        json!(0),
        json!(-0.0),
        json!(1e308),
        json!(-1e308),
        json!(1e39),
        json!(3.5e38),
        json!(1e-320),
        json!(4294967296u64),
        json!(18446744073709551615u64),
        json!(""),
        json!("x"),
        json!([]),
        json!({}),
        json!([0, 0]),
        json!([1e308, 0, 0]),
        json!([0, 0, 0, 0]),
        json!([[0, 0, 0]]),
        json!({"position": [0, 0, 0]}),
    ]
}

/// Numbers that parse as every real field does, and test its range.
const NUMBERS: [f64; 14] = [
    0.0, -0.0, -1.0, 0.5, 1e-320, 1e-30, 1e-7, 7.0, 1e7, 1e30, 3.5e38, 1e39, 1e308, -1e308,
];

/// The same for integer fields (counts, sizes, orders), which refuse a
/// number with a fraction when parsing.
const INTEGERS: [i64; 10] = [0, 1, 2, 7, 9, 65, 100_000, 4_294_967_295, 4_294_967_296, -1];

/// Names of what the scene holds, and of what it does not.
const NAMES: [&str; 5] = ["room", "panel", "walls", "nope", ""];

/// What to do to the request.
#[derive(Clone, Debug)]
enum Edit {
    /// Replace the node at (a hash of) a path by an adversarial value.
    Replace(usize, usize),
    /// Replace a number (the one at a hash of the numbers' paths) by
    /// another of its kind (integer or real): the body still parses, so
    /// the handler's own checks meet it.
    Number(usize, usize),
    /// Replace a string by a name (of the scene's objects and materials,
    /// or none of them).
    Name(usize, usize),
    /// Remove it from its object or array.
    Remove(usize),
    /// Repeat an array's element (or a node in a new array) many times.
    Repeat(usize, usize),
    /// Add an unknown key to an object.
    Unknown(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        3 => (any::<usize>(), any::<usize>()).prop_map(|(p, v)| Edit::Replace(p, v)),
        6 => (any::<usize>(), any::<usize>()).prop_map(|(p, v)| Edit::Number(p, v)),
        1 => (any::<usize>(), any::<usize>()).prop_map(|(p, v)| Edit::Name(p, v)),
        2 => any::<usize>().prop_map(Edit::Remove),
        1 => (any::<usize>(), 2..300usize).prop_map(|(p, n)| Edit::Repeat(p, n)),
        1 => any::<usize>().prop_map(Edit::Unknown),
    ]
}

/// Every node's path: keys of objects and indices of arrays.
fn paths(v: &Value, at: &mut Vec<Vec<Value>>, here: Vec<Value>) {
    match v {
        Value::Object(m) => {
            for (k, child) in m {
                let mut p = here.clone();
                p.push(json!(k));
                paths(child, at, p);
            }
        }
        Value::Array(a) => {
            for (i, child) in a.iter().enumerate() {
                let mut p = here.clone();
                p.push(json!(i));
                paths(child, at, p);
            }
        }
        _ => {}
    }
    at.push(here);
}

fn node<'a>(v: &'a mut Value, path: &[Value]) -> &'a mut Value {
    path.iter().fold(v, |v, k| match k {
        Value::String(k) => &mut v[k.as_str()],
        k => &mut v[k.as_u64().unwrap_or(0) as usize],
    })
}

fn apply(body: &mut Value, edit: &Edit) {
    let mut all = Vec::new();
    paths(body, &mut all, Vec::new());
    let pick = |i: usize| all[i % all.len()].clone();
    let mut of_kind = |i: usize, kind: fn(&Value) -> bool| {
        let found: Vec<_> = all
            .iter()
            .filter(|p| kind(node(body, p)))
            .cloned()
            .collect();
        (!found.is_empty()).then(|| found[i % found.len()].clone())
    };
    match *edit {
        Edit::Number(p, v) => {
            if let Some(path) = of_kind(p, Value::is_number) {
                let number = node(body, &path);
                *number = if number.is_f64() {
                    json!(NUMBERS[v % NUMBERS.len()])
                } else {
                    json!(INTEGERS[v % INTEGERS.len()])
                };
            }
        }
        Edit::Name(p, v) => {
            if let Some(path) = of_kind(p, Value::is_string) {
                *node(body, &path) = json!(NAMES[v % NAMES.len()]);
            }
        }
        Edit::Replace(p, v) => {
            let values = adversarial();
            *node(body, &pick(p)) = values[v % values.len()].clone();
        }
        Edit::Remove(p) => {
            let path = pick(p);
            if let Some((last, parent)) = path.split_last() {
                match (node(body, parent), last) {
                    (Value::Object(m), Value::String(k)) => {
                        m.remove(k);
                    }
                    (Value::Array(a), k) => {
                        let i = k.as_u64().unwrap_or(0) as usize;
                        if i < a.len() {
                            a.remove(i);
                        }
                    }
                    _ => {}
                }
            }
        }
        Edit::Repeat(p, n) => {
            let target = node(body, &pick(p));
            let element = match &*target {
                Value::Array(a) if !a.is_empty() => a[0].clone(),
                other => other.clone(),
            };
            *target = Value::Array(vec![element; n]);
        }
        Edit::Unknown(p) => {
            if let Value::Object(m) = node(body, &pick(p)) {
                m.insert("unexpected".into(), json!([1, "two", null]));
            }
        }
    }
}

/// The scene as served: its document (geometry, transforms, materials)
/// and its revision.
fn served(server: &TestServer) -> (String, u64) {
    let entry = server.state.registry().get("box").expect("the scene");
    let live = entry.read();
    (
        live.scene.to_json().expect("a document"),
        live.acoustic.revision(),
    )
}

/// Sends `body` to `seed`'s route: a success, or a 4xx problem document
/// that leaves the scene as it was. Returns whether it succeeded.
async fn check(server: &TestServer, seed: &Seed, body: &Value) -> Result<bool, TestCaseError> {
    let before = served(server);
    let text = body.to_string();
    let request = match seed.method {
        "PATCH" => patch_json(seed.uri, &text),
        _ => post_json(seed.uri, &text),
    };
    let (status, content_type, bytes) = server.send_raw(request).await;
    let answer = String::from_utf8_lossy(&bytes);
    prop_assert!(
        status.is_success() || status.is_client_error(),
        "{} {}: {status} {answer}\nrequest: {text}",
        seed.method,
        seed.uri
    );
    if !status.is_success() {
        prop_assert_eq!(
            content_type.as_str(),
            "application/problem+json",
            "{}",
            answer
        );
        prop_assert!(
            served(server) == before,
            "refused, yet the scene changed: {text}"
        );
    }
    Ok(status.is_success())
}

/// Each route's own request is accepted, so the edits below start from
/// requests that reach the handlers' depths.
#[tokio::test]
async fn every_seed_is_accepted() {
    let server = small_server().await;
    for seed in seeds() {
        let text = seed.body.to_string();
        let request = match seed.method {
            "PATCH" => patch_json(seed.uri, &text),
            _ => post_json(seed.uri, &text),
        };
        let (status, _, bytes) = server.send_raw(request).await;
        assert!(
            status.is_success(),
            "{} {}: {status} {}",
            seed.method,
            seed.uri,
            String::from_utf8_lossy(&bytes)
        );
    }
}

/// Ids and names no scene or object has, or may have, in every place a
/// route takes one: a 4xx problem each (404 for what does not exist), never
/// a 5xx, and the scene unchanged.
#[tokio::test]
async fn bad_ids_and_names_in_paths_and_queries_are_4xx() {
    let server = small_server().await;
    let before = served(&server);
    let ids = [
        "nope",
        "%00",
        "..%2F..%2Fetc",
        "%E2%80%AE",
        "a%20b",
        "%FF",
        &"x".repeat(5000),
    ];
    for id in ids {
        // "nope" is a free id an upload may take; the others are not ids.
        let upload = (id != "nope").then(|| post_json(&format!("/v1/scenes?id={id}"), BOX_DOC));
        let requests = upload.into_iter().chain([
            get(&format!("/v1/scenes/{id}")),
            delete(&format!("/v1/scenes/{id}")),
            post_json(&format!("/v1/scenes/{id}/rays"), r#"{"rays": []}"#),
            patch_json(
                &format!("/v1/scenes/box/objects/{id}"),
                r#"{"translation": [0, 0, 0]}"#,
            ),
            patch_json(
                &format!("/v1/scenes/{id}/materials"),
                r#"{"materials": {}}"#,
            ),
        ]);
        for request in requests {
            let what = format!("{} {}", request.method(), request.uri());
            let (status, content_type, bytes) = server.send_raw(request).await;
            assert!(
                status.is_client_error(),
                "{what}: {status} {}",
                String::from_utf8_lossy(&bytes)
            );
            assert_eq!(content_type, "application/problem+json", "{what}");
        }
    }
    assert!(served(&server) == before);
}

/// The shoebox with a panel, under limits that keep every case short.
async fn small_server() -> TestServer {
    let server = TestServer::with(|c| {
        c.limits.max_compute_ms = 300;
        c.limits.request_timeout_s = 30;
    });
    let (status, _, out) = server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
    assert_eq!(status, StatusCode::CREATED, "{out}");
    server
}

#[test]
fn bad_input_is_refused_with_a_problem_and_changes_nothing() {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    let server = runtime.block_on(small_server());
    let seeds = seeds();
    let cases = std::env::var("FRUSTA_BAD_INPUT_CASES")
        .ok()
        .and_then(|c| c.parse().ok())
        .unwrap_or(2000);
    let config = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    // The same cases on every run, so that CI fails only on a change.
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    let strategy = (0..seeds.len(), prop::collection::vec(edit(), 1..4));
    let accepted: Vec<std::cell::Cell<u32>> = seeds.iter().map(|_| Default::default()).collect();
    runner
        .run(&strategy, |(route, edits)| {
            let seed = &seeds[route];
            let mut body = seed.body.clone();
            for e in &edits {
                apply(&mut body, e);
            }
            let ok = runtime.block_on(check(&server, seed, &body))?;
            accepted[route].set(accepted[route].get() + u32::from(ok));
            Ok(())
        })
        .unwrap();
    // Edited requests reached every route's handler and some were taken,
    // so the checks above had something to check.
    for (seed, n) in seeds.iter().zip(&accepted) {
        assert!(
            n.get() > 0,
            "no edited request to {} was accepted",
            seed.uri
        );
    }
    // What the accepted edits stored comes back after a restart.
    let before = served(&server);
    let server = server.restart();
    assert_eq!(served(&server), before);
}
