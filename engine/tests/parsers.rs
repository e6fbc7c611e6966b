//! Every parser of outside input, fed garbage and mutations of valid input:
//! an error or a value, never a panic, and nothing unbounded. The corpus
//! holds the shapes hostile clients sent (empty names, repeated and
//! numerous materials, instancing bombs, truncated files).

use frusta_engine::scene::load::{parse_gltf, parse_obj};
use frusta_engine::scene::{Scene, SceneDocument};
use proptest::prelude::*;

const DOCUMENT: &str = r#"{
  "name": "box",
  "materials": {"walls": {"absorption": [0.1, 0.1, 0.2, 0.2, 0.3, 0.3, 0.4, 0.4], "transmission": 0.05}},
  "objects": [
    {"name": "room", "material": "walls",
     "mesh": {"box_room": {"min": [0, 0, 0], "max": [10, 6, 3], "subdivisions": 2}}},
    {"name": "panel", "material": "concrete", "dynamic": true,
     "transform": {"rotation": [0, 0, 0.3826834, 0.9238795], "translation": [1, 2, 0]},
     "mesh": {"vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, 2], [4, 1, 2]],
              "triangles": [[0, 1, 2], [0, 2, 3]]}}
  ]
}"#;

const OBJ: &str = "o box\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl wood_panel\nf 1 2 3\nf 1 3 4\nvn 0 0 1\nf 1//1 2//1 3//1\n";

/// Documents a hostile client sent, each of which must be refused or
/// parsed without harm.
const HOSTILE_DOCUMENTS: &[&str] = &[
    r#"{"objects": [{"name": "", "material": "concrete", "mesh": {"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]]}}]}"#,
    r#"{"materials": {"a": "concrete", "a": "brick"}, "objects": []}"#,
    r#"{"objects": [{"name": "x", "mesh": {"box_room": {"min": [0,0,0], "max": [1,1,1], "subdivisions": 4000000000}}}]}"#,
    r#"{"objects": [{"name": "x", "mesh": {"vertices": [[1e39,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]]}}]}"#,
    r#"{"objects": [{"name": "x", "mesh": {"vertices": [[0,0,0]], "triangles": [[0,0,4294967295]]}}]}"#,
    r#"{"objects": [{"name": "x", "mesh": {"file": "../../etc/passwd"}}]}"#,
    r#"{"objects": [{"name": "x", "transform": {"rotation": [0,0,0,0]}, "mesh": {"vertices": [], "triangles": []}}]}"#,
    r#"{"objects": [], "unknown": 1}"#,
    "[]",
    "",
    "{",
];

/// A document whose materials object lists `count` materials.
fn many_materials(count: usize) -> String {
    let entries: Vec<String> = (0..count)
        .map(|i| format!(r#""m{i}": {{"absorption": 0.1}}"#))
        .collect();
    format!(
        r#"{{"materials": {{{}}}, "objects": []}}"#,
        entries.join(",")
    )
}

/// Parses and, where it parses, builds (uploads cannot name files, so
/// none is given a base directory).
fn parse_and_build(text: &str) {
    if let Ok(document) = SceneDocument::parse(text) {
        let _ = document.build(None);
    }
}

#[test]
fn hostile_documents_are_errors_or_harmless() {
    for doc in HOSTILE_DOCUMENTS {
        parse_and_build(doc);
        assert!(Scene::from_json_str(doc, None).is_err(), "{doc}");
    }
    // 70,000 materials: past the material-id range, refused, quickly.
    let start = std::time::Instant::now();
    let e = Scene::from_json_str(&many_materials(70_000), None).unwrap_err();
    assert!(e.to_string().contains("materials"), "{e}");
    assert!(start.elapsed() < std::time::Duration::from_secs(5));
    assert!(Scene::from_json_str(DOCUMENT, None).is_ok());
}

#[test]
fn truncated_inputs_are_errors_never_panics() {
    for end in 0..DOCUMENT.len() {
        if DOCUMENT.is_char_boundary(end) {
            parse_and_build(&DOCUMENT[..end]);
        }
    }
    for end in 0..OBJ.len() {
        let _ = parse_obj(&OBJ[..end]);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn any_text_is_a_document_or_an_error(text in ".{0,400}") {
        parse_and_build(&text);
    }

    #[test]
    fn mutated_documents_are_documents_or_errors(
        edits in proptest::collection::vec((0usize..4096, any::<char>()), 1..8)
    ) {
        let mut chars: Vec<char> = DOCUMENT.chars().collect();
        for (at, c) in edits {
            let at = at % chars.len();
            chars[at] = c;
        }
        parse_and_build(&chars.into_iter().collect::<String>());
    }

    #[test]
    fn any_text_is_an_obj_or_an_error(text in "([vfo] [-0-9. /e]{0,30}\n|usemtl .{0,10}\n|.{0,20}\n){0,30}") {
        let _ = parse_obj(&text);
    }

    #[test]
    fn any_bytes_are_a_gltf_or_an_error(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        let _ = parse_gltf(&bytes, None, 100_000);
        let mut glb = b"glTF\x02\x00\x00\x00".to_vec();
        glb.extend_from_slice(&bytes);
        let _ = parse_gltf(&glb, None, 100_000);
    }
}
