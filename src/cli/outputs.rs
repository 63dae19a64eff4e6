//! What `skin` and `morph` share: the skin's physical options, and the per-frame outputs
//! (VDB, mesh, stats line, progress), each file written under a temporary name and renamed.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use activeskin::grid::Precision;
use activeskin::render::{self, View};
use activeskin::sequence::FramePattern;
use activeskin::skin::{AnySkin, SkinParams, SpeedParams, StepStats};
use activeskin::target::{Aabb, LevelSetTarget, Target};
use activeskin::vdb::{self, FileMetadata, Grid, WriteOptions};
use activeskin::volume::GridData;
use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};

use super::pattern_arg;
use super::render::parse_size;

/// The skin's physical and numerical options.
#[derive(clap::Args)]
pub struct PhysicsArgs {
    /// Frames per second: the skin advances 1/fps seconds per frame.
    #[arg(long, default_value_t = 24.0)]
    pub fps: f64,
    /// Attraction rate α (1/s): the skin closes α × its distance to the target per second.
    #[arg(long, default_value_t = 4.0)]
    pub alpha: f32,
    /// Surface tension β (world units²/s): smooths, shrinks thin parts and small bubbles.
    #[arg(long, default_value_t = 0.001)]
    pub beta: f32,
    /// Volume preservation gain γ_V (world units/s).
    #[arg(long, default_value_t = 0.0)]
    pub volume_gain: f32,
    /// Area preservation gain γ_A (world units/s).
    #[arg(long, default_value_t = 0.0)]
    pub area_gain: f32,
    /// Voxel size of the skin (default: the target's).
    #[arg(long)]
    pub voxel_size: Option<f32>,
    /// Storage of the potential: f32, or fixed16 (half the memory).
    #[arg(long, value_enum, default_value_t = PrecisionArg::F32)]
    pub precision: PrecisionArg,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum PrecisionArg {
    F32,
    Fixed16,
}

impl PhysicsArgs {
    /// Checked parameters for a skin of voxel size `dx`.
    pub fn params(&self, default_dx: f32) -> anyhow::Result<SkinParams> {
        if !self.fps.is_finite() || self.fps <= 0.0 {
            usage!("--fps must be a positive number");
        }
        for (name, v) in [
            ("--alpha", self.alpha),
            ("--beta", self.beta),
            ("--volume-gain", self.volume_gain),
            ("--area-gain", self.area_gain),
        ] {
            // Rejects NaN as well as negatives.
            if !(v.is_finite() && v >= 0.0) {
                usage!("{name} must be a non-negative number, got {v}");
            }
        }
        let dx = self.voxel_size.unwrap_or(default_dx);
        if !(dx.is_finite() && dx > 0.0) {
            usage!("--voxel-size must be a positive number, got {dx}");
        }
        Ok(SkinParams {
            dx,
            speed: SpeedParams {
                alpha: self.alpha,
                beta: self.beta,
                volume_gain: self.volume_gain,
                area_gain: self.area_gain,
                ..SpeedParams::default()
            },
            precision: match self.precision {
                PrecisionArg::F32 => Precision::F32,
                PrecisionArg::Fixed16 => Precision::Fixed16,
            },
            ..SkinParams::default()
        })
    }
}

/// The files written per frame.
#[derive(clap::Args)]
pub struct OutputArgs {
    /// Skin VDB level sets (grid `surface`): name.####.vdb, name.%04d.vdb, name.$F4.vdb.
    #[arg(long)]
    pub out: Option<String>,
    /// Meshes, OBJ or PLY by extension, same patterns.
    #[arg(long)]
    pub mesh: Option<String>,
    /// Renders: multi-layer EXR (RGBA, Z, N) or PNG by extension, same patterns; the
    /// camera frames the first frame's skin and stays put.
    #[arg(long)]
    pub render: Option<String>,
    /// Render size, WIDTHxHEIGHT.
    #[arg(long, default_value = "640x360")]
    pub render_size: String,
    /// One JSON object per frame (frame, time, sub-steps, band nodes, blocks, area,
    /// volume, Euler characteristic, components, milliseconds).
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Continue from the last skin VDB already written by --out.
    #[arg(long)]
    pub resume: bool,
    /// No progress output.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Writes each frame's outputs and reports progress.
pub struct Outputs {
    out: Option<FramePattern>,
    mesh: Option<FramePattern>,
    render: Option<(FramePattern, (usize, usize), Option<Aabb>)>,
    stats: Option<(PathBuf, Vec<u8>)>,
    progress: ProgressBar,
    plain: bool,
}

/// A usage error unless `pattern`'s files end in one of `extensions`.
fn require_extension(
    flag: &str,
    pattern: &FramePattern,
    what: &str,
    extensions: &[&str],
) -> anyhow::Result<()> {
    let name = pattern.path(0);
    let ext = name.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !extensions.iter().any(|e| ext.eq_ignore_ascii_case(e)) {
        usage!(
            "{flag} '{}': {what} must end in .{}",
            name.display(),
            extensions.join(" or .")
        );
    }
    Ok(())
}

impl Outputs {
    pub fn new(args: &OutputArgs, frames: u64) -> anyhow::Result<Self> {
        let out = args.out.as_deref().map(pattern_arg).transpose()?;
        let mesh = args.mesh.as_deref().map(pattern_arg).transpose()?;
        if let Some(mesh) = &mesh {
            require_extension("--mesh", mesh, "meshes", &["obj", "ply"])?;
        }
        let render = match &args.render {
            Some(spec) => {
                let pattern = pattern_arg(spec)?;
                require_extension("--render", &pattern, "renders", &["exr", "png"])?;
                Some((pattern, parse_size(&args.render_size)?, None))
            }
            None => None,
        };
        if out.is_none() && mesh.is_none() && render.is_none() && args.stats.is_none() {
            usage!("nothing to write: give --out, --mesh, --render or --stats");
        }
        if args.resume && out.is_none() {
            usage!("--resume needs --out: it continues from the last skin VDB written there");
        }
        for pattern in out.iter().chain(&mesh).chain(render.iter().map(|r| &r.0)) {
            let folder = pattern.folder();
            std::fs::create_dir_all(&folder).with_context(|| {
                format!("{}: cannot create the output folder", folder.display())
            })?;
            remove_stale_temporaries(pattern);
        }
        let terminal = std::io::stderr().is_terminal();
        let progress = if args.quiet || !terminal {
            ProgressBar::hidden()
        } else {
            let bar = ProgressBar::new(frames);
            bar.set_style(
                ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} frames, {elapsed} ({eta} left) {msg}",
                )
                .expect("a valid progress template"),
            );
            bar
        };
        Ok(Outputs {
            out,
            mesh,
            render,
            stats: args.stats.clone().map(|p| (p, Vec::new())),
            progress,
            plain: !args.quiet && !terminal,
        })
    }

    /// The skin VDB of a frame, if --out was given and the file exists.
    pub fn written_skin(&self, frame: i64) -> Option<PathBuf> {
        let path = self.out.as_ref()?.path(frame);
        path.is_file().then_some(path)
    }

    /// Writes one frame; returns the level set written, for [`AnySkin::restore`].
    pub fn write_frame(
        &mut self,
        frame: i64,
        skin: &AnySkin,
        stats: &StepStats,
        started: Instant,
    ) -> anyhow::Result<Option<GridData>> {
        let mut written = None;
        if let Some(pattern) = &self.out {
            let path = pattern.path(frame);
            let data = skin.to_level_set();
            let grid = Grid::from_data(&data)?;
            let meta = FileMetadata {
                creator: format!("activeskin {}", env!("CARGO_PKG_VERSION")),
                has_frame: true,
                frame,
            };
            vdb::write_grids(&path, &[(&grid, WriteOptions::default())], &meta)?;
            written = Some(data);
        }
        if let Some(pattern) = &self.mesh {
            skin.mesh().write(&pattern.path(frame))?;
        }
        if let Some((pattern, size, camera)) = &mut self.render {
            let data = match &written {
                Some(data) => data,
                None => &skin.to_level_set(),
            };
            let dx = data.transform.voxel_size() as f32;
            let target = LevelSetTarget::new(data);
            let bounds = target.bounds();
            let frame_box = *camera.get_or_insert_with(|| {
                bounds.padded(0.25 * (bounds.max - bounds.min).max_element())
            });
            render::render(&target, frame_box, View::Perspective, *size, dx)
                .write(&pattern.path(frame))?;
        }
        let ms = started.elapsed().as_secs_f64() * 1e3;
        let line = serde_json::json!({
            "frame": frame,
            "time": skin.time(),
            "substeps": stats.substeps,
            "band_nodes": stats.band_nodes,
            "blocks": stats.blocks,
            "area": stats.area,
            "volume": stats.volume,
            "euler_characteristic": stats.euler_characteristic,
            "components": stats.components,
            "milliseconds": ms,
        });
        if let Some((path, lines)) = &mut self.stats {
            lines.extend_from_slice(line.to_string().as_bytes());
            lines.push(b'\n');
            write_file(path, lines)?;
        }
        if self.plain {
            println!(
                "frame {frame}: {} sub-steps, {} band nodes, area {:.4}, volume {:.4}, χ {}, {} component(s), {ms:.0} ms",
                stats.substeps,
                stats.band_nodes,
                stats.area,
                stats.volume,
                stats.euler_characteristic,
                stats.components,
            );
        }
        self.progress.inc(1);
        Ok(written)
    }

    /// Keeps the stats of frames already written when resuming: the lines before `frame`.
    pub fn resume_stats(&mut self, frame: i64) -> anyhow::Result<()> {
        let Some((path, lines)) = &mut self.stats else {
            return Ok(());
        };
        let Ok(old) = std::fs::read_to_string(&*path) else {
            return Ok(());
        };
        for line in old.lines() {
            let value: serde_json::Value = serde_json::from_str(line).with_context(|| {
                format!(
                    "{}: not a stats file (one JSON object per line)",
                    path.display()
                )
            })?;
            if value["frame"].as_i64().is_some_and(|f| f < frame) {
                lines.extend_from_slice(line.as_bytes());
                lines.push(b'\n');
            }
        }
        Ok(())
    }

    pub fn skip(&self, frames: u64) {
        self.progress.inc(frames);
    }

    pub fn finish(&self) {
        self.progress.finish_and_clear();
    }
}

/// Removes the temporary files a killed run left behind for this pattern's frames
/// (`.NAME.PID.tmp`, see [`activeskin::io::temporary_path`]).
fn remove_stale_temporaries(pattern: &FramePattern) {
    let folder = pattern.folder();
    let Ok(entries) = std::fs::read_dir(&folder) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(inner) = name.strip_prefix('.').and_then(|n| n.strip_suffix(".tmp")) else {
            continue;
        };
        let Some((frame_file, pid)) = inner.rsplit_once('.') else {
            continue;
        };
        let frame_path = pattern.path(0).with_file_name(frame_file);
        let ours = pid.bytes().all(|b| b.is_ascii_digit())
            && frame_path
                .to_str()
                .and_then(|p| pattern.frame_of(p))
                .is_some();
        if ours {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

fn write_file(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    activeskin::io::write_atomically(path, |tmp| {
        std::fs::File::create(tmp)
            .and_then(|mut f| f.write_all(bytes))
            .map_err(|e| e.to_string())
    })
    .map_err(|m| anyhow::anyhow!("{}: {m}", path.display()))
}
