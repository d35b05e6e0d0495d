//! Progress on long work, drawn on stderr with indicatif: one style for every command (stimulus
//! builds, contact sheets, video renders). A bar draws only when stderr is a terminal, so logs and
//! tests see nothing.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A bar over `len` units of work (`unit` names them, e.g. "frames"), with `message` before it.
pub fn bar(len: u64, unit: &str, message: impl Into<String>) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    let template = format!("{{spinner}} {{msg}} [{{bar:30}}] {{pos}}/{{len}} {unit}, {{elapsed}} elapsed, eta {{eta}}");
    bar.set_style(ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()).progress_chars("=> "));
    bar.set_message(message.into());
    bar
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_bar_counts_its_units() {
        let bar = super::bar(3, "frames", "sheet");
        bar.inc(2);
        assert_eq!((bar.position(), bar.length()), (2, Some(3)));
        bar.finish_and_clear();
    }
}
