//! Running the benchmark binary from its tests.

use std::ffi::OsStr;
use std::process::Command;

/// Runs `frusta-bench` with `args`, asserts it succeeded (showing its
/// stderr if not) and returns what it printed.
pub fn run_bench<S: AsRef<OsStr>>(args: impl IntoIterator<Item = S>) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_frusta-bench"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}
