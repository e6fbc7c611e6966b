//! Property tests of the stream's message parser and merge: any text is
//! answered without a panic; a refused message changes nothing queued; an
//! accepted one leaves at most one edit per object, holding the newest
//! value of each field, as a model kept here predicts.

use std::collections::BTreeMap;

use frusta_engine::geometry::MAX_COORDINATE;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use serde_json::{json, Value};

use super::*;
use crate::routes::test_support::*;

/// Messages the service has been sent or could be: the cases of the
/// reliability review among them.
const CORPUS: &[&str] = &[
    "",
    "null",
    "[]",
    "{}",
    "{\"seq\": -1}",
    "{\"seq\": 18446744073709551616}",
    "{\"options\": {\"air\": {\"humidity_percent\": 200}}}",
    "{\"options\": {\"max_order\": 99}, \"sources\": [{\"position\": [1, 1, 1]}], \"listeners\": [{\"position\": [2, 2, 2]}]}",
    "{\"sources\": [], \"listeners\": [{\"position\": [2, 2, 2]}]}",
    "{\"sources\": [{\"position\": [1e39, 0, 0]}]}",
    "{\"objects\": [{\"object\": \"panel\", \"translation\": [0, 1, 0], \"vertices\": [[0, 0, 0]]}]}",
    "{\"objects\": [{\"object\": \"panel\"}]}",
    "{\"objects\": [{\"object\": \"panel\", \"rotation\": [0, 0, 0, 0]}]}",
    "{\"objects\": [{\"object\": \"panel\", \"translation\": [0, 1]}]}",
    "{\"objects\": [{\"object\": \"panel\", \"colour\": \"red\"}]}",
    "{\"objects\": {\"object\": \"panel\"}}",
    "{\"objects\": [{\"object\": 1, \"translation\": [0, 1, 0]}]}",
    "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]",
    "{\"seq\": 1, \"seq\": 2}",
    "\u{0}\u{feff}{}",
];

/// One generated object move and whether it must be accepted.
#[derive(Clone, Debug)]
struct Move {
    object: &'static str,
    index: Option<usize>,
    rotation: Option<[f64; 4]>,
    translation: Option<[f64; 3]>,
    vertices: Option<Vec<[f64; 3]>>,
}

impl Move {
    fn valid(&self) -> bool {
        let fits = |x: &f64| x.abs() < f64::from(f32::MAX);
        let rotation_ok = self.rotation.is_none_or(|q| {
            q.iter().all(fits) && q.iter().map(|x| x * x).sum::<f64>().sqrt() >= 1e-5
        });
        // A mesh's coordinates, and an object's translation, stay within
        // the engine's range.
        let in_range = |x: &f64| x.abs() <= f64::from(MAX_COORDINATE);
        let translation_ok = self.translation.is_none_or(|t| t.iter().all(in_range));
        let vertices_ok = self.vertices.as_ref().is_none_or(|v| {
            // Four corners at one point: no triangle has area.
            let collapsed = v.iter().all(|p| *p == v[0]);
            self.index == Some(1) && v.len() == 4 && v.iter().flatten().all(in_range) && !collapsed
        });
        let something =
            self.rotation.is_some() || self.translation.is_some() || self.vertices.is_some();
        self.index.is_some() && something && rotation_ok && translation_ok && vertices_ok
    }

    fn to_json(&self) -> Value {
        let mut m = json!({"object": self.object});
        if let Some(r) = self.rotation {
            m["rotation"] = json!(r);
        }
        if let Some(t) = self.translation {
            m["translation"] = json!(t);
        }
        if let Some(v) = &self.vertices {
            m["vertices"] = json!(v);
        }
        m
    }
}

/// Components: mostly ordinary, sometimes past f32 (not finite once read)
/// or past the range a mesh may hold (finite, but refused as a vertex).
fn component() -> impl Strategy<Value = f64> {
    prop_oneof![8 => -100.0..100.0f64, 1 => Just(1e39), 1 => Just(1e20), 1 => Just(0.0)]
}

fn object_move() -> impl Strategy<Value = Move> {
    let names = prop_oneof![
        Just(("panel", Some(1))),
        Just(("1", Some(1))),
        Just(("room", Some(0))),
        Just(("0", Some(0))),
        Just(("ghost", None)),
        Just(("2", None)),
        Just(("", None)),
    ];
    let quat = prop_oneof![
        3 => prop::array::uniform4(component()),
        1 => Just([0.0; 4]),
    ];
    // Offsets of the panel's corners: a shift keeps its triangles whole.
    let panel = [
        [4.0, 1.0, 0.5],
        [4.0, 2.0, 0.5],
        [4.0, 2.0, 2.0],
        [4.0, 1.0, 2.0],
    ];
    let vertices = prop_oneof![
        4 => prop::array::uniform3(component())
            .prop_map(move |d| panel.iter().map(|p| [p[0] + d[0], p[1] + d[1], p[2] + d[2]]).collect()),
        1 => prop::collection::vec(prop::array::uniform3(-5.0..5.0f64), 0..8),
        1 => prop::array::uniform3(-5.0..5.0f64).prop_map(|p| vec![p; 4]),
    ];
    (
        names,
        prop::option::of(quat),
        prop::option::of(prop::array::uniform3(component())),
        prop::option::weighted(0.3, vertices),
    )
        .prop_map(|((object, index), rotation, translation, vertices)| Move {
            object,
            index,
            rotation,
            translation,
            vertices,
        })
}

/// JSON of any shape, with keys the protocol uses among others.
fn any_json() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        Just(Value::Null),
        any::<bool>().prop_map(Value::from),
        any::<i64>().prop_map(Value::from),
        (-1e40..1e40f64).prop_map(Value::from),
        "[a-z\\\\\"\u{0}-\u{7f}]{0,8}".prop_map(Value::from),
    ];
    leaf.prop_recursive(4, 32, 6, |inner| {
        let key = prop_oneof![
            Just("seq".to_owned()),
            Just("sources".to_owned()),
            Just("listeners".to_owned()),
            Just("options".to_owned()),
            Just("position".to_owned()),
            "[a-z_]{1,6}",
        ];
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..6).prop_map(Value::Array),
            prop::collection::btree_map(key, inner, 0..6)
                .prop_map(|m| Value::Object(m.into_iter().collect())),
        ]
    })
}

#[derive(Clone, Debug)]
enum Message {
    Corpus(&'static str),
    Json(Value),
    Moves(Option<u64>, Vec<Move>),
}

fn message() -> impl Strategy<Value = Message> {
    prop_oneof![
        1 => prop::sample::select(CORPUS).prop_map(Message::Corpus),
        2 => any_json().prop_map(Message::Json),
        4 => (prop::option::of(0..1000u64), prop::collection::vec(object_move(), 1..4))
            .prop_map(|(seq, moves)| Message::Moves(seq, moves)),
    ]
}

/// What the queue should hold per object: newest rotation, translation
/// and vertices.
type Queued = BTreeMap<usize, (Option<[f32; 4]>, Option<[f32; 3]>, Option<Vec<[f32; 3]>>)>;

fn queued(stream: &Stream) -> Queued {
    stream
        .pending
        .objects
        .iter()
        .map(|(i, e)| {
            let vertices = e
                .vertices
                .as_ref()
                .map(|v| v.iter().map(|p| p.to_array()).collect());
            (*i, (e.rotation, e.translation, vertices))
        })
        .collect()
}

#[test]
fn stream_messages_are_parsed_and_merged_all_or_nothing() {
    let runtime = tokio::runtime::Runtime::new().unwrap();
    let server = TestServer::new();
    runtime.block_on(server.send(post_json("/v1/scenes?id=box", BOX_DOC)));
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<_>>();
    let mut runner = TestRunner::new(Config {
        cases: 200,
        ..Config::default()
    });
    let messages = prop::collection::vec(message(), 1..12);
    runner
        .run(&messages, |messages| {
            let mut stream = super::tests::stream(&server);
            let mut model = Queued::new();
            for message in messages {
                let before = (queued(&stream), stream.pending.seq);
                let text = match &message {
                    Message::Corpus(text) => (*text).to_owned(),
                    Message::Json(value) => value.to_string(),
                    Message::Moves(seq, moves) => {
                        json!({"seq": seq, "objects": moves.iter().map(Move::to_json).collect::<Vec<_>>()})
                            .to_string()
                    }
                };
                let result = stream.merge(&text);
                if result.is_err() {
                    prop_assert_eq!((queued(&stream), stream.pending.seq), before, "{} was refused yet changed the queue", text);
                    continue;
                }
                if let Message::Moves(seq, moves) = &message {
                    let expected = moves.iter().all(Move::valid);
                    prop_assert!(expected, "{} was accepted", text);
                    for m in moves {
                        let slot = model.entry(m.index.expect("valid")).or_default();
                        if let Some(r) = m.rotation {
                            slot.0 = Some(f32s(&r).try_into().unwrap());
                        }
                        if let Some(t) = m.translation {
                            slot.1 = Some(f32s(&t).try_into().unwrap());
                        }
                        if let Some(v) = &m.vertices {
                            slot.2 = Some(v.iter().map(|p| f32s(p).try_into().unwrap()).collect());
                        }
                    }
                    if seq.is_some() {
                        prop_assert_eq!(stream.pending.seq, *seq);
                    }
                }
                prop_assert_eq!(queued(&stream), model.clone(), "after {}", text);
            }
            Ok(())
        })
        .unwrap();
}

#[test]
fn valid_moves_are_accepted() {
    // The other direction of the oracle: a move the model calls valid is
    // never refused (a parser that refused everything would pass above).
    let runtime = tokio::runtime::Runtime::new().unwrap();
    let server = TestServer::new();
    runtime.block_on(server.send(post_json("/v1/scenes?id=box", BOX_DOC)));
    let mut runner = TestRunner::new(Config {
        cases: 200,
        ..Config::default()
    });
    runner
        .run(&object_move(), |m| {
            let mut stream = super::tests::stream(&server);
            let text = json!({"objects": [m.to_json()]}).to_string();
            prop_assert_eq!(stream.merge(&text).is_ok(), m.valid(), "{}", text);
            Ok(())
        })
        .unwrap();
}
