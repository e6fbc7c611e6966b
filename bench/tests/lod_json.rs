//! `frusta-bench lod --json --save DIR` runs end to end on the 10k hall,
//! prints the documented fields (for rays, the impulse-response fields
//! `null`; for impulse responses, the rays' fields), uses planes at a
//! coarse bound and none at bound 0, and saves the run with its
//! provenance.

mod common;

#[test]
fn lod_json_has_the_documented_fields() {
    let dir = std::env::temp_dir().join(format!("frusta-lod-json-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let stdout = common::run_bench([
        "lod",
        "--hall",
        "10k",
        "--rays",
        "4096",
        "--bound",
        "0",
        "--bound",
        "2",
        "--ir-hall",
        "10k",
        "--ir-bound",
        "2",
        "--order",
        "1",
        "--sampling",
        "2",
        "--rounds",
        "1",
        "--json",
        "--save",
        dir.to_str().unwrap(),
    ]);
    let doc: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("lod.json")).unwrap()).unwrap();
    assert_eq!(doc["runs"], saved["runs"]);
    assert_eq!(saved["commit"].as_str().unwrap().len(), 40);
    let all = doc["runs"].as_array().unwrap();
    let (runs, responses): (Vec<_>, Vec<_>) = all.iter().partition(|r| r["query"] == "rays");
    assert_eq!(runs.len(), 2);
    for (r, bound) in runs.iter().zip([0.0, 2.0]) {
        assert_eq!(r["scene"], "hall-10k");
        assert_eq!(r["query"], "rays");
        assert_eq!(r["lod_bound"].as_f64(), Some(bound));
        for field in ["ms", "exact_ms"] {
            assert!(r[field].as_f64().unwrap() > 0.0, "{field}: {r}");
        }
        for field in ["frusta", "energy_error_db_max", "parameter_error_jnd_max"] {
            assert!(r[field].is_null(), "{field}: {r}");
        }
        assert!(r["hit_displacement_max"].as_f64().unwrap() >= 0.0, "{r}");
    }
    // Exact geometry at bound 0; planes answer some rays at 2 m.
    assert_eq!(runs[0]["plane_hits"], 0);
    assert_eq!(runs[0]["hit_displacement_max"].as_f64(), Some(0.0));
    assert!(runs[1]["plane_hits"].as_u64().unwrap() > 0, "{}", runs[1]);
    // One impulse-response row per cell assignment at 2 m, simplified
    // (fewer triangles than the hall's 9972), every band's energy compared.
    assert_eq!(responses.len(), 2);
    for (r, cells) in responses.iter().zip(["sampled", "conservative"]) {
        assert_eq!(r["query"], "ir");
        assert_eq!(r["cells"], cells);
        assert_eq!(r["lod_bound"].as_f64(), Some(2.0));
        for field in ["ms", "exact_ms", "energy_error_db_max"] {
            assert!(r[field].as_f64().unwrap() >= 0.0, "{field}: {r}");
        }
        assert!(r["frusta"].as_u64().unwrap() > 0, "{r}");
        assert!(r["polygons"].as_u64().unwrap() > 0, "{r}");
        assert!(r["triangles"].as_u64().unwrap() < 9972, "{r}");
        assert!(r["hit_displacement_max"].is_null(), "{r}");
        assert!(r["tail_noise_db"].as_f64().is_some(), "{r}");
    }
    let scenes = doc["scenes"].as_array().unwrap();
    assert!(scenes[0]["lod_bytes"].as_u64().unwrap() > 0);
    std::fs::remove_dir_all(&dir).unwrap();
}
