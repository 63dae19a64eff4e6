//! `activeskin farm --chunks K -- skin|particles ARGS...`: a shot cut into K chunks of
//! frames, one Slurm array task each. A chunk starts `--warmup` frames early, so it meets
//! the sequential run at its first frame; each resumes from its own written frames, so a
//! failed task is resubmitted alone.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command as Process;

use anyhow::Context;
use clap::FromArgMatches;

use super::{particles, skin, Cli, Command};

#[derive(clap::Args)]
pub struct FarmArgs {
    /// Chunks of frames, one farm task each.
    #[arg(long)]
    chunks: i64,
    /// Frames each chunk starts before its first, advancing without writing: a number, or
    /// `auto`, enough for the start to fade under 0.05 voxel (ln(40)·fps/α).
    #[arg(long, default_value = "auto")]
    warmup: String,
    /// Print the batch script instead of writing and submitting it.
    #[arg(long)]
    dry_run: bool,
    /// The batch script to write and submit (kept, to resubmit a failed chunk alone).
    #[arg(long, default_value = "activeskin-farm.sh")]
    script: PathBuf,
    /// Folder of the tasks' logs, one per chunk.
    #[arg(long, default_value = "farm-logs")]
    logs: PathBuf,
    /// The job's name on the farm.
    #[arg(long, default_value = "activeskin")]
    name: String,
    /// An sbatch option for every task, e.g. --sbatch=--partition=render (repeatable).
    #[arg(long = "sbatch", allow_hyphen_values = true)]
    sbatch: Vec<String>,
    /// The command each chunk runs: `skin` or `particles` and its options, after `--`.
    #[arg(last = true, required = true)]
    command: Vec<String>,
}

pub fn run(args: &FarmArgs) -> anyhow::Result<()> {
    let inner = std::iter::once("activeskin".to_string()).chain(args.command.iter().cloned());
    let matches = super::command_line()
        .try_get_matches_from(inner)
        .map_err(|e| super::bad_usage(first_line(&e.to_string())))?;
    let cli = Cli::from_arg_matches(&matches)
        .map_err(|e| super::bad_usage(first_line(&e.to_string())))?;
    let shot = match &cli.command {
        Command::Skin(a) => skin::shot(a)?,
        Command::Particles(a) => particles::shot(a)?,
        _ => usage!("farm runs skin or particles: activeskin farm --chunks K -- skin ARGS..."),
    };
    if shot.physics.warmup.is_some() {
        usage!("give --warmup to farm, not to the command it runs");
    }
    if shot.outputs.out.is_none() {
        usage!("farm needs --out: a chunk resubmitted after a failure resumes from its skin VDBs");
    }
    let warmup = shot.physics.warmup_of(Some(&args.warmup))?;
    let (first, last) = shot.range;
    let frames = last - first + 1;
    if !(1..=frames).contains(&args.chunks) {
        usage!(
            "--chunks must be 1 to the shot's {frames} frames ({first}-{last}), got {}",
            args.chunks
        );
    }
    let chunks = split(shot.range, args.chunks);
    let mut command = chunk_command(&args.command)?;
    command.extend(shot.fixed.iter().map(|w| quote(w)));
    if shot.outputs.usd.is_some() {
        // Each chunk's USD stage lists the whole shot, the same file from every chunk.
        command.extend(["--shot-frames".into(), format!("{first}-{last}")]);
    }
    // The baseline binary, not its twin: each node of a mixed farm chooses for its CPU.
    let exe = super::twin::program().context("cannot tell where activeskin is")?;
    let here = std::env::current_dir().context("cannot read the current folder")?;
    let script = batch_script(
        &Batch {
            name: &args.name,
            chunks: &chunks,
            warmup,
            logs: &here.join(&args.logs),
            folder: &here,
            sbatch: &args.sbatch,
            script: &args.script,
        },
        &exe,
        &command,
    );
    if args.dry_run {
        print!("{script}");
        return Ok(());
    }
    std::fs::create_dir_all(&args.logs)
        .with_context(|| format!("{}: cannot create the log folder", args.logs.display()))?;
    activeskin::io::write_atomically(&args.script, |tmp| std::fs::write(tmp, &script))
        .with_context(|| format!("{}", args.script.display()))?;
    let submitted = Process::new("sbatch")
        .arg("--parsable")
        .arg(&args.script)
        .output()
        .map_err(|e| {
            anyhow::anyhow!(
                "cannot run sbatch ({e}): is this a Slurm submit host? --dry-run prints the script"
            )
        })?;
    if !submitted.status.success() {
        anyhow::bail!(
            "sbatch refused {}: {}",
            args.script.display(),
            first_line(&String::from_utf8_lossy(&submitted.stderr))
        );
    }
    let stdout = String::from_utf8_lossy(&submitted.stdout);
    let id = stdout.trim().split(';').next().unwrap_or_default();
    println!(
        "submitted job array {id}: {} chunks of frames {first}-{last}, each warmed up {warmup} frames",
        chunks.len()
    );
    println!(
        "watch: squeue -j {id}   logs: {}/{}-{id}_N.log",
        args.logs.display(),
        args.name
    );
    println!(
        "a failed chunk N resumes alone: sbatch --array=N {}",
        args.script.display()
    );
    Ok(())
}

/// The shot's frames in `k` contiguous chunks, the first ones a frame longer when they do
/// not divide evenly.
fn split((first, last): (i64, i64), k: i64) -> Vec<(i64, i64)> {
    let n = last - first + 1;
    let mut start = first;
    (0..k)
        .map(|i| {
            let len = n / k + i64::from(i < n % k);
            let chunk = (start, start + len - 1);
            start += len;
            chunk
        })
        .collect()
}

/// The inner command for a chunk, as shell words: without the options each chunk sets
/// itself (`--frames`, `--resume`, `--shot-frames`), its stats file named after the chunk's frames (the
/// chunks run at once, each writes its own). `--render` is refused: a run's camera frames
/// its own first skin, so chunks would frame differently.
fn chunk_command(command: &[String]) -> anyhow::Result<Vec<String>> {
    let mut out = Vec::new();
    let mut words = command.iter();
    while let Some(word) = words.next() {
        let (option, inline) = match word.split_once('=') {
            Some((o, v)) if o.starts_with("--") => (o, Some(v.to_string())),
            _ => (word.as_str(), None),
        };
        let mut value = || {
            inline
                .clone()
                .or_else(|| words.next().cloned())
                .unwrap_or_default()
        };
        match option {
            "--frames" | "--shot-frames" => {
                value();
            }
            "--resume" => {}
            "--render" => usage!(
                "farm cannot cut a run with --render (each chunk would frame its own camera): farm the VDBs or meshes, and render them afterwards"
            ),
            "--stats" => {
                let path = value();
                let (stem, extension) = match path.rsplit_once('.') {
                    Some((stem, ext)) if !ext.contains('/') => (stem.to_string(), format!(".{ext}")),
                    _ => (path.clone(), String::new()),
                };
                out.push("--stats".into());
                out.push(format!(
                    "{}.\"${{CHUNKS[$SLURM_ARRAY_TASK_ID]}}\"{}",
                    quote(&stem),
                    if extension.is_empty() { String::new() } else { quote(&extension) }
                ));
            }
            _ => out.push(quote(word)),
        }
    }
    Ok(out)
}

struct Batch<'a> {
    name: &'a str,
    chunks: &'a [(i64, i64)],
    warmup: i64,
    logs: &'a Path,
    folder: &'a Path,
    sbatch: &'a [String],
    /// Where the script is written, for the line saying how to run one chunk by hand.
    script: &'a Path,
}

/// A Slurm batch script running chunk `$SLURM_ARRAY_TASK_ID` of `command` (shell words).
fn batch_script(batch: &Batch, exe: &Path, command: &[String]) -> String {
    let mut s = String::from("#!/bin/bash\n");
    let last = batch.chunks.len() - 1;
    let _ = writeln!(s, "#SBATCH --job-name={}", batch.name);
    let _ = writeln!(s, "#SBATCH --array=0-{last}");
    let _ = writeln!(s, "#SBATCH --chdir={}", batch.folder.display());
    let _ = writeln!(
        s,
        "#SBATCH --output={}/{}-%A_%a.log",
        batch.logs.display(),
        batch.name
    );
    for option in batch.sbatch {
        let _ = writeln!(s, "#SBATCH {option}");
    }
    let (first, end) = (batch.chunks[0].0, batch.chunks[last].1);
    let _ = writeln!(
        s,
        "# activeskin farm: frames {first}-{end} in {} chunks, each started {} frames early.\n\
         # One chunk without Slurm: SLURM_ARRAY_TASK_ID=N bash {}",
        batch.chunks.len(),
        batch.warmup,
        batch.script.display()
    );
    s += "set -euo pipefail\n";
    let ranges: Vec<String> = batch
        .chunks
        .iter()
        .map(|(a, b)| format!("{a}-{b}"))
        .collect();
    let _ = writeln!(s, "CHUNKS=({})", ranges.join(" "));
    let words: Vec<String> = std::iter::once(quote(&exe.display().to_string()))
        .chain(command.iter().cloned())
        .collect();
    let _ = writeln!(
        s,
        "exec {} --frames \"${{CHUNKS[$SLURM_ARRAY_TASK_ID]}}\" --warmup {} --resume",
        words.join(" "),
        batch.warmup
    );
    s
}

/// `word` as one shell word.
fn quote(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%#".contains(c));
    if plain {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

fn first_line(text: &str) -> String {
    text.lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or_default()
        .trim_start_matches("error: ")
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_cover_the_shot_once_in_order() {
        for (range, k) in [((1, 96), 4), ((1001, 1010), 3), ((5, 5), 1), ((-3, 3), 7)] {
            let chunks = split(range, k);
            assert_eq!(chunks.len() as i64, k);
            assert_eq!(chunks[0].0, range.0);
            assert_eq!(chunks.last().unwrap().1, range.1);
            for pair in chunks.windows(2) {
                assert_eq!(pair[0].1 + 1, pair[1].0);
            }
            let lengths: Vec<i64> = chunks.iter().map(|(a, b)| b - a + 1).collect();
            assert!(lengths.iter().max().unwrap() - lengths.iter().min().unwrap() <= 1);
        }
    }

    #[test]
    fn the_chunk_sets_its_own_frames_resume_and_stats() {
        let words = |s: &str| s.split(' ').map(String::from).collect::<Vec<_>>();
        let given =
            "skin --frames 1-9 --target a.####.vdb --resume --frames=3-4 -q --stats s/st.jsonl --shot-frames 1-9";
        let expected =
            r#"skin --target a.####.vdb -q --stats s/st."${CHUNKS[$SLURM_ARRAY_TASK_ID]}".jsonl"#;
        assert_eq!(chunk_command(&words(given)).unwrap(), words(expected));
        assert!(chunk_command(&words("skin --render r.####.png")).is_err());
        assert!(chunk_command(&words("skin --render=r.####.png")).is_err());
    }

    #[test]
    fn words_are_quoted_for_the_shell() {
        assert_eq!(quote("a.####.vdb"), "a.####.vdb");
        assert_eq!(quote("my shot/a.$F4.vdb"), "'my shot/a.$F4.vdb'");
        assert_eq!(quote("it's"), r"'it'\''s'");
        assert_eq!(quote(""), "''");
    }
}
