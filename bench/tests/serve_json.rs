//! `frusta-bench serve --quick --json` on the shoebox: every phase answers
//! without errors and reports sane figures (no timing is asserted).

mod common;

#[test]
fn shoebox_quick_load_and_streams_have_no_errors() {
    let stdout = common::run_bench([
        "serve",
        "--quick",
        "--json",
        "--scene",
        "shoebox",
        "--clients",
        "4",
        "--seconds",
        "1",
        "--stream-seconds",
        "0.5",
    ]);
    let rows: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let phases: Vec<(&str, Option<&str>)> = rows
        .iter()
        .map(|r| (r["kind"].as_str().unwrap(), r["moving"].as_str()))
        .collect();
    assert_eq!(
        phases,
        [
            ("ir_load", None),
            ("stream", Some("listener")),
            ("stream", Some("source"))
        ]
    );
    for r in &rows {
        assert_eq!(r["scene"], "shoebox");
        assert_eq!(r["errors"], 0, "{r}");
        let requests = r["requests"].as_u64().unwrap();
        assert!(requests > 0, "{r}");
        assert!(r["per_s"].as_f64().unwrap() > 0.0, "{r}");
        let l = &r["latency_ms"];
        let (p50, p99, max) = (l["p50"].as_f64(), l["p99"].as_f64(), l["max"].as_f64());
        assert!(p50 > Some(0.0) && p50 <= p99 && p99 <= max, "{r}");
        let (peak, after) = (r["peak_rss_mib"].as_f64(), r["rss_after_mib"].as_f64());
        assert!(after > Some(1.0) && peak >= after, "{r}");
    }
    assert_eq!(rows[0]["clients"], 4);
    assert_eq!(rows[1]["options"]["max_order"], 4);
    // Only the first listener update traces; a moving source (5 cm an
    // update) traces again once it is 0.25 m from its last trace, and
    // reuses the frusta in between.
    let reused = |r: &serde_json::Value| r["beams_reused"].as_u64().unwrap();
    assert_eq!(reused(&rows[1]), rows[1]["requests"].as_u64().unwrap() - 1);
    let source_updates = rows[2]["requests"].as_u64().unwrap();
    assert!(
        reused(&rows[2]) > 0 && reused(&rows[2]) < source_updates,
        "{}",
        rows[2]
    );
}
