//! Collision queries end to end: the real server on a loopback port, and
//! `frusta-client`.

use frusta_client::api::collisions::{CollisionKind, CollisionRequest};
use frusta_client::api::objects::{ObjectMove, ObjectPatch};
use frusta_client::api::stream::StreamUpdate;
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

#[test]
fn a_stream_subscribed_to_collisions_answers_each_move_with_its_contacts() {
    let data = DataDir::new("collide-stream");
    let server = Server::start(&data);
    server.post("/v1/scenes", CRATES);
    let mut stream = server.client().stream("crates").expect("connect");
    let subscribe = StreamUpdate {
        seq: Some(1),
        collisions: Some(CollisionRequest {
            kind: CollisionKind::Continuous,
            ..Default::default()
        }),
        ..Default::default()
    };
    stream.send(&subscribe).unwrap();
    let first = stream.collisions_for(1).unwrap();
    assert_eq!((first.collisions.total, first.collisions.revision), (0, 0));
    // b slides halfway to a (no contact), then on through it.
    for (seq, x, meets) in [(2, -0.5, false), (3, -1.5, true)] {
        let update = StreamUpdate {
            seq: Some(seq),
            objects: Some(shift_b(x)),
            ..Default::default()
        };
        stream.send(&update).unwrap();
        let answer = stream.collisions_for(seq).unwrap();
        assert_eq!(answer.objects.len(), 1, "the move is reported");
        assert_eq!(
            answer.collisions.earliest_time.is_some(),
            meets,
            "{answer:?}"
        );
        if meets {
            // From x = 2.5 (b's near face) to 1.5, a's face at 2 is met
            // halfway.
            let t = answer.collisions.earliest_time.unwrap();
            assert!(t <= 0.5 && t > 0.5 - 1e-4, "{t}");
        }
    }
    // Moves in the subscription itself are refused; the stream stays open.
    let wrong = StreamUpdate {
        seq: Some(4),
        collisions: Some(CollisionRequest {
            moves: shift_b(0.0),
            ..Default::default()
        }),
        ..Default::default()
    };
    stream.send(&wrong).unwrap();
    assert!(stream.collisions_for(4).is_err());
    // Someone else moves b back out: the stream answers with no contact.
    let (status, _, _) = server.patch(
        "/v1/scenes/crates/objects/b",
        r#"{"translation": [0, 0, 0]}"#,
    );
    assert_eq!(status, 200);
    loop {
        match stream.read().unwrap() {
            frusta_client::Received::Collisions(c) if c.collisions.revision == 3 => {
                assert_eq!(c.collisions.total, 0);
                break;
            }
            _ => {}
        }
    }
    stream.close().unwrap();
}
