//! `frusta-bench collide --json --save DIR` runs end to end on a small
//! cloth and a bundled scene moving through its copy, prints the
//! documented fields and saves them with their provenance.

mod common;

#[test]
fn collide_json_has_the_documented_fields() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/shoebox.json");
    let dir = std::env::temp_dir().join(format!("frusta-collide-json-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let dir_arg = dir.to_str().unwrap();
    let stdout = common::run_bench([
        "collide", "--cloth", "24", "--mesh", scene, "--frames", "4", "--rounds", "1", "--json",
        "--save", dir_arg,
    ]);
    let doc: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("collide.json")).unwrap()).unwrap();
    assert_eq!(doc["runs"], saved["runs"]);
    assert_eq!(saved["commit"].as_str().unwrap().len(), 40);
    assert!(std::fs::read_to_string(dir.join("collide.txt"))
        .unwrap()
        .starts_with("command: "));

    let runs = doc["runs"].as_array().unwrap();
    // Two cases, each with AABB and OBB, with and without a front.
    assert_eq!(runs.len(), 8);
    for r in runs {
        assert!(
            ["self", "pair"].contains(&r["kind"].as_str().unwrap()),
            "{r}"
        );
        assert!(["aabb", "obb"].contains(&r["bv"].as_str().unwrap()), "{r}");
        assert!(r["front"].is_boolean(), "{r}");
        assert!(r["triangles"].as_u64().unwrap() >= 12, "{r}");
        assert!(r["ms_per_frame"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["parry3d_ms_per_frame"].as_f64().unwrap() > 0.0, "{r}");
        // The folds and the moving copy make contacts, which parry finds
        // too (it may report more: its test has a tolerance).
        let pairs = r["pairs"].as_u64().unwrap();
        assert!(pairs > 0, "{r}");
        assert!(
            r["parry3d_pairs"].as_u64().unwrap() + r["parry3d_missed_pairs"].as_u64().unwrap()
                >= pairs,
            "{r}"
        );
    }
    assert_eq!(runs[0]["case"], "cloth");
    assert_eq!(runs[0]["triangles"], 2 * 24 * 24);
    assert_eq!(runs[4]["case"], "shoebox");
}
