//! The command line: parses arguments with clap and calls the library. The only place where
//! errors become messages for people (with `anyhow` context) and exit codes.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate::facs::Catalog;

#[derive(Parser)]
#[command(name = "facslab", version, about = "FACS-controlled facial-expression stimuli, studies and validation reports")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the Action Units facslab can show.
    ///
    /// Example: facslab catalog
    Catalog,
}

/// Runs the command line and returns the process exit code.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    match dispatch(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}

fn dispatch(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Catalog => {
            for unit in Catalog::built_in().iter() {
                let side = if unit.unilateral { "L/R" } else { "" };
                println!("{:>3}  {:<26} {:<22} {:<4} {}", unit.code, unit.name, unit.region.label(), side, unit.appearance);
            }
            Ok(())
        }
    }
}
