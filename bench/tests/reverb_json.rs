//! `frusta-bench reverb --json` runs end to end on the shoebox: both box
//! rooms report per band, and `--seeds` reports each room's spread over
//! seeds, against the exact image sources where it has them and against
//! the seeds' own mean where it does not.

mod common;

#[test]
fn reverb_json_reports_the_spread_over_seeds() {
    let stdout = common::run_bench([
        "reverb",
        "--scene",
        "shoebox",
        "--rays",
        "512",
        "--length",
        "0.5",
        "--rounds",
        "1",
        "--seeds",
        "3",
        "--no-peer",
        "--json",
    ]);
    let out: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let runs = out["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 2, "the room as it is, and without scattering");
    for run in runs {
        let specular = run["scene"].as_str().unwrap().contains("no scattering");
        assert_eq!(run["bands"].as_array().unwrap().len(), 8, "{run}");
        let spread = run["seed_spread"].as_array().expect("a spread over seeds");
        assert!(!spread.is_empty(), "{run}");
        for band in spread {
            assert_eq!(band["seeds"], 3);
            assert_eq!(band["against_exact"], specular, "{band}");
            for parameter in ["edt", "t20", "t30"] {
                let s: Vec<f64> = band[parameter]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_f64().unwrap())
                    .collect();
                let [mean, least, greatest, sd] = s[..] else {
                    panic!("mean, least, greatest, sd: {band}");
                };
                assert!(least <= mean && mean <= greatest && sd >= 0.0, "{band}");
                if !specular {
                    // Against their own mean, the seeds average nothing.
                    assert!(mean.abs() < 1e-9, "{band}");
                }
            }
        }
    }
}
