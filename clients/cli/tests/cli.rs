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

#[test]
fn ir_shoebox_gives_the_129_image_sources_and_a_wav_that_auralizes() {
    let dir = std::env::temp_dir().join(format!("frusta-cli-ir-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let ir = dir.join("ir.wav");
    let out = frusta(&[
        "ir",
        "--shoebox",
        "10,6,3",
        "--absorption",
        "0.1",
        "--source",
        "2,3,1.5",
        "--listener",
        "7.1,2.3,1.2",
        "--max-order",
        "4",
        "--sampling",
        "8",
        "--no-air",
        "--json",
        "--out",
        ir.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{out:?}");
    let doc = stdout_json(&out);
    let paths = doc["paths"].as_array().unwrap();
    assert_eq!(paths.len(), 129);
    assert_eq!(doc["bands_hz"].as_array().unwrap().len(), 8);
    // The direct path: no surfaces, gain 1/r with air absorption off.
    let direct = &paths[0];
    assert_eq!(direct["order"], 0);
    let r = direct["distance_m"].as_f64().unwrap();
    let expected = ((7.1f64 - 2.0).powi(2) + 0.7f64.powi(2) + 0.3f64.powi(2)).sqrt();
    assert!((r - expected).abs() < 1e-5, "{r} vs {expected}");
    let g = direct["pressure_gain"][4].as_f64().unwrap();
    assert!((g - 1.0 / r).abs() < 1e-5);
    // A first-order path carries sqrt(1 - 0.1) per reflection.
    let first = paths.iter().find(|p| p["order"] == 1).unwrap();
    let g1 = first["pressure_gain"][0].as_f64().unwrap() * first["distance_m"].as_f64().unwrap();
    assert!((g1 - 0.9f64.sqrt()).abs() < 1e-5, "{g1}");
    assert!(doc["stats"]["frusta"].as_u64().unwrap() > 0);
    assert!(doc["parameters"][4]["edt_s"].as_f64().is_some());

    let wet = dir.join("wet.wav");
    let out = frusta(&[
        "auralize",
        "--ir",
        ir.to_str().unwrap(),
        "--dry",
        ir.to_str().unwrap(),
        "--out",
        wet.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{out:?}");
    assert!(std::fs::metadata(&wet).unwrap().len() > std::fs::metadata(&ir).unwrap().len());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn ir_rejects_bad_input_with_a_message() {
    let out = frusta(&[
        "ir",
        "--scene",
        SHOEBOX,
        "--source",
        "2,3,1.5",
        "--listener",
        "1,1,1",
        "--sampling",
        "0",
    ]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("sampling"),
        "{out:?}"
    );
    let out = frusta(&["ir", "--source", "2,3,1.5", "--listener", "1,1,1"]);
    assert!(!out.status.success());
}

#[cfg(unix)]
#[test]
fn a_reader_that_stops_early_does_not_make_frusta_panic() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_frusta"))
        .args([
            "ir",
            "--scene",
            SHOEBOX,
            "--source",
            "2,3,1.5",
            "--listener",
            "7,2,1.2",
            "--max-order",
            "6",
            "--json",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    // 600 kB of JSON: far more than a pipe buffers, so frusta is still
    // writing when the reader goes.
    assert!(first.starts_with('{'), "{first}");
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn ir_binaural_writes_two_channels_and_sampled_cells_run() {
    let dir = std::env::temp_dir().join(format!("frusta-cli-binaural-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let wav = dir.join("ir.wav");
    let out = frusta(&[
        "ir",
        "--scene",
        SHOEBOX,
        "--source",
        "2,3,1.5",
        "--listener",
        "7,2,1.2",
        "--binaural",
        "--cells",
        "sampled",
        "--sample-rate",
        "16000",
        "--out",
        wav.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{out:?}");
    let (rate, channels) = frusta_engine::acoustics::signal::read_wav(&wav).unwrap();
    assert_eq!(rate, 16000);
    assert_eq!(channels.len(), 2);
    // The listener faces +X and the source is at its +Y side: the left ear
    // (first channel) is louder.
    let energy = |c: &[f32]| c.iter().map(|x| x * x).sum::<f32>();
    assert!(energy(&channels[0]) > energy(&channels[1]));
    std::fs::remove_dir_all(&dir).ok();
}
