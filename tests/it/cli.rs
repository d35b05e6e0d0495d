//! Helpers for running the `facslab` binary.

use std::path::Path;
use std::process::{Command, Output};

/// Runs `facslab ARGS` in `dir` and returns its output.
pub fn facslab(dir: &Path, args: &[&str]) -> Output {
    let output = Command::new(env!("CARGO_BIN_EXE_facslab"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the facslab binary runs");
    if std::env::var_os("FACSLAB_TEST_VERBOSE").is_some() {
        eprintln!("$ facslab {}\n{}{}", args.join(" "), String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    }
    output
}

/// Runs `facslab ARGS` and fails the test, printing everything, unless it succeeds.
pub fn facslab_ok(dir: &Path, args: &[&str]) -> Output {
    let output = facslab(dir, args);
    assert!(
        output.status.success(),
        "facslab {} failed in {}:\nstdout:\n{}\nstderr:\n{}",
        args.join(" "),
        dir.display(),
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}
