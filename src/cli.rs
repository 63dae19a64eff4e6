//! The `activeskin` command line. `anyhow` lives here only; the library has typed errors.

mod info;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "activeskin",
    version,
    about = "Active implicit skins for VDB, particle and analytic targets"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print the grids of VDB files: name, type, class, voxel size, active voxels, bounds.
    Info {
        /// VDB files to describe.
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
}

/// Runs the command line; exit code 0 on success, 1 on bad data, 2 on bad usage (clap).
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Info { files } => info::run(&files),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("activeskin: error: {e:#}");
            ExitCode::from(1)
        }
    }
}
