//! The `facslab` binary: parses the command line and hands it to [`facslab::cli::run`].

use std::process::ExitCode;

fn main() -> ExitCode {
    facslab::engine::keep_freed_memory();
    facslab::web::log::install();
    facslab::cli::run()
}
