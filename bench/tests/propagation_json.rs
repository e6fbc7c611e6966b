//! `frusta-bench propagation --quick --json --scene shoebox` finds every
//! image source and nothing else, measured against the independent
//! reference, and says where the run came from.

mod common;

#[test]
fn shoebox_quick_sweep_has_full_recall_and_no_false_paths() {
    let stdout = common::run_bench([
        "propagation",
        "--quick",
        "--json",
        "--scene",
        "shoebox",
        "--no-peer",
    ]);
    let mut lines: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let provenance = lines.pop().unwrap();
    let provenance = &provenance["provenance"];
    for field in ["command", "commit", "machine"] {
        assert!(!provenance[field].is_null(), "{provenance}");
    }
    let rows = lines;
    // Two cell modes x N in {4, 8} x orders {2, 4}.
    assert_eq!(rows.len(), 8, "{rows:?}");
    for r in &rows {
        assert_eq!(r["scene"], "shoebox");
        assert_eq!(r["triangles"], 12);
        let recall = r["recall"].as_f64().unwrap();
        if r["impl"] == "frusta" {
            assert_eq!(recall, 1.0, "{r}");
        } else {
            assert_eq!(r["impl"], "frusta-sampled");
            assert!(recall > 0.95, "{r}");
        }
        assert_eq!(r["false_paths"].as_u64(), Some(0), "{r}");
        assert!(r["frusta"].as_u64().unwrap() > 0, "{r}");
        assert!(r["time_ms"].as_f64().unwrap() > 0.0, "{r}");
        assert_eq!(r["reference"], "independent", "{r}");
        assert!(r["reference_ms"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["exhaustive_ms"].as_f64().unwrap() > 0.0, "{r}");
        // f32 geometry and gains against the f64 closed form.
        assert!(r["max_time_error_s"].as_f64().unwrap() < 1e-9, "{r}");
        for band in r["max_energy_error_db"].as_array().unwrap() {
            assert!(band.as_f64().unwrap() < 1e-4, "{r}");
        }
        if recall == 1.0 {
            for band in r["total_energy_error_db"].as_array().unwrap() {
                assert!(band.as_f64().unwrap().abs() < 1e-3, "{r}");
            }
        }
    }
    // Exact counts of a 10 x 6 x 3 m box: 25 paths to order 2, 129 to order 4.
    let exact: Vec<u64> = rows.iter().map(|r| r["exact"].as_u64().unwrap()).collect();
    assert_eq!(exact, [25, 25, 129, 129, 25, 25, 129, 129]);
}
