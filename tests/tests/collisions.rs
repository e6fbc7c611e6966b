//! Collision queries end to end: the real server on a loopback port, and
//! `frusta-client`.

use frusta_client::api::collisions::{CollisionKind, CollisionRequest};
use frusta_client::api::objects::{ObjectMove, ObjectPatch};
use frusta_tests::*;
use serde_json::json;

/// Two closed 1 m crates, a metre apart along x.
const CRATES: &str = r#"{
  "name": "crates",
  "materials": {"wood": {"absorption": 0.1}},
  "objects": [
    {"name": "a", "material": "wood",
     "mesh": {"box_room": {"min": [1, 1, 1], "max": [2, 2, 2]}}},
    {"name": "b", "material": "wood",
     "mesh": {"box_room": {"min": [3, 1, 1], "max": [4, 2, 2]}}}
  ]
}"#;

fn shift_b(x: f32) -> Vec<ObjectMove> {
    vec![ObjectMove {
        object: "b".into(),
        patch: ObjectPatch {
            translation: Some([x, 0.0, 0.0]),
            ..Default::default()
        },
    }]
}

#[test]
fn crates_moved_into_each_other_touch_and_a_motion_meets_first_at_two_thirds() {
    let data = DataDir::new("collide");
    let server = Server::start(&data);
    let (status, _, created) = server.post("/v1/scenes", CRATES);
    assert_eq!(status, 201, "{created}");
    let client = server.client();
    let apart = client
        .collisions("crates", &CollisionRequest::default())
        .unwrap();
    assert_eq!(apart.total, 0);
    // b's near face (x = 3) sweeps to x = 1.5, through a's far face (x = 2)
    // after 1 m of 1.5.
    let swept = client
        .collisions(
            "crates",
            &CollisionRequest {
                kind: CollisionKind::Continuous,
                moves: shift_b(-1.5),
                ..Default::default()
            },
        )
        .unwrap();
    let t = swept.earliest_time.expect("the crates meet");
    assert!(t <= 2.0 / 3.0 && t > 2.0 / 3.0 - 1e-4, "{t}");
    assert_eq!(swept.revision, 1);
    assert!(swept
        .contacts
        .iter()
        .all(|c| c.a.object == "a" && c.b.object == "b"));
    // Where the motion left b, the crates overlap.
    let now = client
        .collisions("crates", &CollisionRequest::default())
        .unwrap();
    assert!(now.total > 0);
    assert_eq!(now.revision, 1);
    // Moved back by PATCH, they are apart again.
    let (status, _, _) = server.patch(
        "/v1/scenes/crates/objects/b",
        r#"{"translation": [0, 0, 0]}"#,
    );
    assert_eq!(status, 200);
    let (status, _, out) = server.post("/v1/scenes/crates/collisions", "{}");
    assert_eq!((status, &out["total"]), (200, &json!(0)));
}

#[test]
fn bad_collision_queries_are_4xx_problems_and_store_nothing() {
    let data = DataDir::new("collide-bad");
    let server = Server::start(&data);
    server.post("/v1/scenes", CRATES);
    for (body, status) in [
        (r#"{"pairs": [["a", "c"]]}"#, 404),
        (r#"{"kind": "proximity"}"#, 422),
        (
            r#"{"moves": [{"object": "b", "vertices": [[0, 0, 0]]}]}"#,
            422,
        ),
        (
            r#"{"moves": [{"object": "b", "rotation": [0, 0, 0, 0]}]}"#,
            422,
        ),
        (r#"{"kind": "continuous", "tolerance": -1}"#, 422),
        (r#"{"pairs": "all"}"#, 422),
    ] {
        let (got, content_type, problem) = server.post("/v1/scenes/crates/collisions", body);
        assert_eq!(got, status, "{body}: {problem}");
        assert_eq!(content_type, "application/problem+json", "{body}");
    }
    assert_eq!(server.post("/v1/scenes/none/collisions", "{}").0, 404);
    let (_, _, detail) = server.get("/v1/scenes/crates");
    assert_eq!(detail["revision"], 0);
}
