//! Process start-up: a whole `facslab` process that loads the face model and the people
//! (`facslab identities`) beside one that loads nothing (`facslab --version`); the difference
//! is what loading the assets costs. Run with `cargo bench --bench startup`.

use std::process::{Command, Stdio};

fn main() {
    divan::main();
}

fn run(args: &[&str]) {
    let status = Command::new(env!("CARGO_BIN_EXE_facslab")).args(args).stdout(Stdio::null()).status().expect("facslab runs");
    assert!(status.success(), "facslab {args:?} failed");
}

/// The process alone: argument parsing and exit, no assets.
#[divan::bench(sample_count = 50)]
fn version() {
    run(&["--version"]);
}

/// The process with the face model and the built-in people loaded.
#[divan::bench(sample_count = 50)]
fn identities() {
    run(&["identities"]);
}
