//! `frusta-bench shadows --json --save DIR` runs end to end on the
//! bunny in a room (a point light, the sun, a panel), prints the
//! documented fields, finds selective equal to full ray tracing on every
//! pixel, and saves the run with its provenance.

mod common;

#[test]
fn shadows_json_has_the_documented_fields() {
    let dir = std::env::temp_dir().join(format!("frusta-shadows-json-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let stdout = common::run_bench([
        "shadows",
        "--scene",
        "bunny-room",
        "--size",
        "96",
        "--map",
        "64",
        "--frames",
        "2",
        "--json",
        "--save",
        dir.to_str().unwrap(),
    ]);
    let doc: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("shadows.json")).unwrap()).unwrap();
    assert_eq!(doc["runs"], saved["runs"]);
    assert_eq!(saved["commit"].as_str().unwrap().len(), 40);
    let runs = doc["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 3);
    let kinds = [("hard", "point"), ("hard", "sun"), ("soft", "panel")];
    for (r, (shadows, light)) in runs.iter().zip(kinds) {
        assert_eq!(r["scene"], "bunny-room");
        assert_eq!(r["shadows"], shadows);
        assert_eq!(r["light"], light);
        assert_eq!(
            (r["width"].as_u64(), r["height"].as_u64()),
            (Some(96), Some(96))
        );
        for field in ["full_ms", "selective_ms", "shadow_map_ms"] {
            assert!(r[field].as_f64().unwrap() > 0.0, "{field}: {r}");
        }
        let pip = r["pip_fraction"].as_f64().unwrap();
        assert!(pip > 0.0 && pip < 1.0, "{r}");
        assert_eq!(r["wrong_pixels"], 0, "{r}");
    }
    assert_eq!(runs[2]["samples"], 16);
    // The bunny's room has no stage: no seats.
    assert_eq!(doc["seats"].as_array().unwrap().len(), 0);
}
