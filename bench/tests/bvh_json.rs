//! `frusta-bench bvh --json` runs end to end and prints the documented fields.

use std::process::Command;

#[test]
fn bvh_json_has_the_documented_fields() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/shoebox.json");
    let out = Command::new(env!("CARGO_BIN_EXE_frusta-bench"))
        .args([
            "bvh",
            "--mesh",
            scene,
            "--rays",
            "4096",
            "--build-runs",
            "1",
            "--trace-runs",
            "1",
        ])
        .args(["--only", "frusta,parry3d", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["mesh"], "shoebox");
    assert!(report["triangles"].as_u64().unwrap() >= 12);
    let results = report["results"].as_array().unwrap();
    assert_eq!(results.len(), 2);
    for r in results {
        for key in ["build_ms", "sah_cost", "bytes_per_triangle"] {
            assert!(r[key].as_f64().unwrap() > 0.0, "{key} in {r}");
        }
        assert!(r.get("refit_ms").is_some());
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
    }
    assert_eq!(results[0]["impl"], "frusta");
    // The cross-check ran: peers agree but for rays grazing edges.
    assert!(results[1]["mismatch_fraction"].as_f64().unwrap() < 0.01);
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
