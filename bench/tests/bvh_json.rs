//! `frusta-bench bvh --json --save DIR` runs end to end, prints the
//! documented fields and saves them with their provenance.

use std::process::Command;

mod common;

#[test]
fn bvh_json_has_the_documented_fields() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/shoebox.json");
    let dir = std::env::temp_dir().join(format!("frusta-bvh-json-{}", std::process::id()));
    let stdout = common::run_bench([
        "bvh",
        "--mesh",
        scene,
        "--rays",
        "4096",
        "--rounds",
        "3",
        "--build-runs",
        "1",
        "--only",
        "parry3d",
        "--json",
        "--save",
        dir.to_str().unwrap(),
    ]);
    let doc: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("bvh.json")).unwrap()).unwrap();
    assert_eq!(doc, saved);
    assert!(doc["command"].as_str().unwrap().contains("bvh --mesh"));
    assert_eq!(doc["commit"].as_str().unwrap().len(), 40);
    assert!(doc["machine"]["threads"].as_u64().unwrap() >= 1);
    assert!(!doc["machine"]["cpu"].as_str().unwrap().is_empty());
    assert_eq!(doc["rounds"], 3);
    let text = std::fs::read_to_string(dir.join("bvh.txt")).unwrap();
    assert!(text.starts_with("command: "), "{text}");
    assert!(text.contains("mesh shoebox"), "{text}");

    let report = &doc["meshes"][0];
    assert_eq!(report["mesh"], "shoebox");
    assert!(report["triangles"].as_u64().unwrap() >= 12);
    let results = report["results"].as_array().unwrap();
    // Ours always runs: it is the reference of the ratios.
    assert_eq!(results.len(), 2);
    assert_eq!(results[0]["impl"], "frusta");
    assert!(results[0]["vs_frusta"].is_null());
    for r in results {
        for key in ["build_ms", "refit_ms", "sah_cost", "bytes_per_triangle"] {
            assert!(r[key].as_f64().unwrap() > 0.0, "{key} in {r}");
        }
        for key in [
            "coherent_closest",
            "incoherent_closest",
            "coherent_any",
            "incoherent_any",
        ] {
            assert!(
                r["mrays_per_s"][key].as_f64().unwrap() > 0.0,
                "{key} in {r}"
            );
        }
        assert_eq!(r["rounds"].as_array().unwrap().len(), 3);
        // The refit was checked against brute force, and held.
        assert!(r["refit_check"]["checked"].as_u64().unwrap() > 0, "{r}");
        assert_eq!(r["refit_check"]["wrong"], 0, "{r}");
    }
    let parry = &results[1];
    assert_eq!(parry["parallel_build"], false);
    assert!(parry["vs_frusta"]["build"].as_f64().unwrap() > 0.0);
    // The cross-check ran: peers agree but for rays grazing edges.
    assert!(parry["mismatch_fraction"].as_f64().unwrap() < 0.01);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bad_mesh_path_is_a_clear_error() {
    let out = Command::new(env!("CARGO_BIN_EXE_frusta-bench"))
        .args(["bvh", "--mesh", "/nonexistent/model.obj"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("model.obj"));
}
