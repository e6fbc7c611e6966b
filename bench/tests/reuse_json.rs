//! `frusta-bench reuse --json` runs end to end on the L-room: updates that
//! trace every move find every path a fresh trace finds and nothing else,
//! a reuse distance makes later updates reuse, and bad arguments are
//! errors before any trace.

mod common;

use std::process::Command;

#[test]
fn reuse_json_reports_recall_against_fresh_traces() {
    let stdout = common::run_bench([
        "reuse",
        "--scene",
        "l-room",
        "--order",
        "2",
        "--sampling",
        "2",
        "--updates",
        "4",
        "--reuse",
        "0",
        "--reuse",
        "0.25",
        "--json",
    ]);
    let rows: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2);
    let (every, kept) = (&rows[0], &rows[1]);
    for r in rows {
        assert_eq!(r["scene"], "l-room");
        assert_eq!(r["cells"], "conservative");
        assert_eq!(r["updates"], 4);
        assert!(r["fresh_paths"].as_u64().unwrap() > 0, "{r}");
        assert!(r["update_mean_ms"].as_f64().unwrap() > 0.0, "{r}");
    }
    // Tracing every move is a fresh trace at every position.
    assert_eq!(every["reused"], 0);
    assert_eq!(every["found"], every["fresh_paths"]);
    assert_eq!(every["recall"], 1.0);
    assert_eq!(every["others"], 0);
    // 5 cm steps within 0.25 m: every update after the first reuses.
    assert_eq!(kept["reused"], 3);
    assert!(kept["recall"].as_f64().unwrap() > 0.9, "{kept}");
}

#[test]
fn bad_arguments_are_errors_before_any_trace() {
    for args in [
        &["--updates", "0"][..],
        &["--radius", "0"][..],
        &["--step", "NaN"][..],
        &["--reuse=-0.5"][..],
        &["--reuse", "11"][..],
        &["--scene", "nowhere"][..],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_frusta-bench"))
            .arg("reuse")
            .args(args)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("error"),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}
