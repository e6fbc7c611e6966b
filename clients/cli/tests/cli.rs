//! Runs the `frusta` binary on the bundled shoebox and on bad input.

use std::process::{Command, Output};

const SHOEBOX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/shoebox.json");

fn frusta(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_frusta"))
        .args(args)
        .output()
        .expect("run frusta")
}

fn stdout_json(output: &Output) -> serde_json::Value {
    serde_json::from_slice(&output.stdout).expect("JSON on stdout")
}

#[test]
fn scene_info_prints_counts_and_stats() {
    let out = frusta(&["scene", "info", SHOEBOX]);
    assert!(out.status.success(), "{out:?}");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("triangles  12"), "{text}");
    assert!(text.contains("room"), "{text}");
    assert!(text.contains("walls"), "{text}");

    let out = frusta(&["scene", "info", SHOEBOX, "--json"]);
    assert!(out.status.success(), "{out:?}");
    let doc = stdout_json(&out);
    assert_eq!(doc["triangles"], 12);
    assert_eq!(doc["objects"][0]["name"], "room");
    assert_eq!(doc["bvh"]["triangles"], 12);
    assert!(doc["build_ms"].as_f64().is_some());
}

#[test]
fn trace_hits_the_far_wall() {
    let args = [
        "trace",
        "--scene",
        SHOEBOX,
        "--origin",
        "2,3,1.5",
        "--direction",
        "3,0,0",
    ];
    let out = frusta(&[&args[..], &["--json"]].concat());
    assert!(out.status.success(), "{out:?}");
    let hit = &stdout_json(&out)["hit"];
    assert!((hit["t"].as_f64().expect("t") - 8.0).abs() < 1e-4, "{hit}");
    assert_eq!(hit["material"], "walls");

    let out = frusta(&args);
    assert!(out.status.success(), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("distance  8"));
}

#[test]
fn trace_accepts_negative_components_and_reports_misses() {
    let out = frusta(&[
        "trace",
        "--scene",
        SHOEBOX,
        "--origin",
        "-5,3,1.5",
        "--direction",
        "-1,0,0",
    ]);
    assert!(out.status.success(), "{out:?}");
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "no hit");
}

#[test]
fn bad_input_fails_cleanly() {
    let cases: [&[&str]; 4] = [
        &["scene", "info", "no/such/scene.json"],
        &[
            "trace",
            "--scene",
            "no/such/scene.json",
            "--origin",
            "0,0,0",
            "--direction",
            "1,0,0",
        ],
        &[
            "trace",
            "--scene",
            SHOEBOX,
            "--origin",
            "1,1,1",
            "--direction",
            "0,0,0",
        ],
        &[
            "trace",
            "--scene",
            SHOEBOX,
            "--origin",
            "1,1",
            "--direction",
            "1,0,0",
        ],
    ];
    for args in cases {
        let out = frusta(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(stderr.contains("error"), "{args:?}: {stderr}");
    }
    let out = frusta(&["scene", "info", "no/such/scene.json"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such/scene.json"));
}
