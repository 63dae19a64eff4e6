//! The `activeskin` command line. `anyhow` lives here only; the library has typed errors.

/// Returns a [`Usage`] error: the command line itself is wrong (exit code 2).
macro_rules! usage {
    ($($arg:tt)*) => {
        return Err(anyhow::Error::new($crate::cli::Usage(format!($($arg)*))))
    };
}

mod args;
mod demo;
mod farm;
mod info;
mod mesh;
mod morph;
mod particles;
mod progress;
mod render;
mod skin;
pub mod twin;
mod validate;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "activeskin",
    version,
    about = "Active implicit skins for VDB, particle and analytic targets"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// The most memory a run may take, in GB [default: three quarters of the machine's
    /// memory, or of `ulimit -v` when smaller]: a frame that would need more stops with
    /// one line, before allocating, naming what asks for it.
    #[arg(long, global = true, value_name = "GB")]
    max_memory: Option<f64>,
}

#[derive(Subcommand)]
enum Command {
    /// Print the grids of VDB files: name, type, class, voxel size, active voxels, bounds.
    Info {
        /// VDB files to describe.
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Dress a VDB target sequence (level sets, or fog volumes with --iso) with a skin.
    Skin(skin::SkinArgs),
    /// Dress a particle sequence (PLY, VTK, VTU, BGEO, VDB points, JSON, CSV, XYZ) with a skin.
    Particles(particles::ParticlesArgs),
    /// Morph a skin from one shape to another, writing a VDB (and mesh) sequence.
    Morph(morph::MorphArgs),
    /// Render a level set (or a fog volume at --iso) to a multi-layer EXR or a PNG.
    Render(render::RenderArgs),
    /// Compare our mesh and measures with OpenVDB's on a level set (exit 1 when out of
    /// tolerance).
    Validate(validate::ValidateArgs),
    /// Ours and OpenVDB side by side: step throughput, meshing, memory, scaling.
    Bench(crate::bench::BenchArgs),
    /// The built-in demo: the Fig. 7 morph, a moving target and a particle splash, written to ./out.
    Demo(demo::DemoArgs),
    /// Mesh a level set (or a fog volume at --iso) with activeskin's polygonizer.
    Mesh(mesh::MeshArgs),
    /// Cut a `skin` or `particles` run into chunks of frames, each warmed up, and submit
    /// them as one Slurm job array (or print the batch script).
    Farm(farm::FarmArgs),
}

/// The command line with clap's settings, for the process and for `farm`'s inner command.
fn command_line() -> clap::Command {
    // `--alpha -1` is a bad value, not an unknown option: it reaches the commands' own
    // checks and their one-line usage errors.
    Cli::command()
        .version(twin::VERSION)
        .mut_subcommands(|c| c.allow_negative_numbers(true))
}

/// A mistake in the command line itself: a bad option value, a pattern without a frame
/// number or matching no file, an empty frame range. Exit code 2, as clap's own.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Usage(pub String);

/// Turns any error about an argument into a [`Usage`] error.
pub fn bad_usage(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::Error::new(Usage(e.to_string()))
}

/// A note of the library's on standard error, its fields said as flags.
pub fn note(line: &str) {
    eprintln!("activeskin: {}", activeskin::field::on_command_line(line));
}

/// A frame pattern given on the command line.
pub fn pattern_arg(spec: &str) -> anyhow::Result<activeskin::sequence::FramePattern> {
    activeskin::sequence::FramePattern::parse(spec).map_err(bad_usage)
}

/// clap's message about a command line in one line: its `error:` line and its tip,
/// pointing to `--help` for the rest (its usage block).
fn one_line_usage(message: &str) -> String {
    let mut lines = message.lines().map(str::trim).filter(|l| !l.is_empty());
    let mut first = lines
        .next()
        .unwrap_or("bad command line")
        .trim_start_matches("error:")
        .trim()
        .to_string();
    // "the following required arguments were not provided:" lists them below.
    let mut rest = lines.peekable();
    if first.ends_with(':') {
        let mut listed = Vec::new();
        while let Some(l) = rest.next_if(|l| !l.starts_with("Usage:") && !l.starts_with("tip:")) {
            listed.push(l);
        }
        first = format!("{first} {}", listed.join(", "));
    }
    match rest.find_map(|l| l.strip_prefix("tip:")) {
        Some(tip) => format!("{first} ({}); see --help", tip.trim()),
        None => format!("{first}; see --help"),
    }
}

/// Runs the command line; exit code 0 on success, 1 on bad data, 2 on bad usage.
pub fn run() -> ExitCode {
    let matches = command_line()
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m));
    let cli = match matches {
        Ok(cli) => cli,
        // Help and version as clap prints them; a mistake in one line, as every error.
        Err(e)
            if !e.use_stderr()
                || e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand =>
        {
            e.exit()
        }
        Err(e) => {
            eprintln!("activeskin: error: {}", one_line_usage(&e.to_string()));
            return ExitCode::from(2);
        }
    };
    if let Some(gb) = cli.max_memory {
        if !(gb.is_finite() && gb > 0.0) {
            eprintln!("activeskin: error: --max-memory must be a positive number of GB, got {gb}");
            return ExitCode::from(2);
        }
        activeskin::budget::set_bytes((gb * 1e9) as u64);
    }
    let result = match cli.command {
        Command::Info { files } => info::run(&files),
        Command::Skin(args) => skin::run(&args),
        Command::Morph(args) => morph::run(&args),
        Command::Particles(args) => particles::run(&args),
        Command::Mesh(args) => mesh::run(&args),
        Command::Demo(args) => demo::run(&args),
        Command::Render(args) => render::run(&args),
        Command::Validate(args) => validate::run(&args),
        Command::Bench(args) => crate::bench::run(&args),
        Command::Farm(args) => farm::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // Each cause once: a library error's message already holds its causes.
            let line = activeskin::field::on_command_line(&activeskin::io::error_chain(e.as_ref()));
            eprintln!("activeskin: error: {line}");
            let usage = e.downcast_ref::<Usage>().is_some()
                || matches!(
                    e.downcast_ref::<activeskin::frames::FrameError>(),
                    Some(activeskin::frames::FrameError::Usage(_))
                );
            ExitCode::from(if usage { 2 } else { 1 })
        }
    }
}
