//! Progress bars (on stderr) for work a person waits on. They are hidden
//! when stdout is not a terminal or the output is JSON, so that scripts
//! and logs get only the results.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressStyle};

/// Whether to draw bars for a command printing JSON (`as_json`) or not.
pub fn shown(as_json: bool) -> bool {
    !as_json && std::io::stdout().is_terminal()
}

/// A bar counting bytes, for uploads.
pub fn bytes(len: u64, show: bool) -> ProgressBar {
    bar(
        len,
        show,
        "{msg} [{bar:30}] {bytes}/{total_bytes} {bytes_per_sec}",
    )
}

/// A bar counting steps, for stream updates.
pub fn steps(len: u64, show: bool) -> ProgressBar {
    bar(len, show, "{msg} [{bar:30}] {pos}/{len} {per_sec}")
}

fn bar(len: u64, show: bool, template: &str) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let style = ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
    ProgressBar::new(len).with_style(style)
}
