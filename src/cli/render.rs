//! `activeskin render IN.vdb OUT.exr|OUT.png`: a ray-marched look at a level set (or a fog
//! volume at --iso).

use std::path::PathBuf;

use activeskin::render::{self, Up, View};
use anyhow::Context;

use activeskin::frames::read_target;

#[derive(clap::Args)]
pub struct RenderArgs {
    /// A VDB file.
    input: PathBuf,
    /// The image: .exr (RGBA, Z, N layers) or .png.
    output: PathBuf,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "640x480")]
    size: String,
    #[arg(long, value_enum, default_value_t = ViewArg::Perspective)]
    view: ViewArg,
    /// The scene's up axis: y (Houdini, Maya) or z (Blender).
    #[arg(long, value_enum, default_value_t = UpArg::Y)]
    up: UpArg,
    /// Grid name, `name[1]` for a second grid of one name, or index in the file
    /// (default: `surface` or `phi`, Houdini's and Mantaflow's level sets, else the first float grid).
    #[arg(long)]
    grid: Option<String>,
    /// Surface density, for fog volumes.
    #[arg(long)]
    iso: Option<f32>,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum ViewArg {
    Front,
    Side,
    Top,
    Perspective,
}

impl From<ViewArg> for View {
    fn from(v: ViewArg) -> View {
        match v {
            ViewArg::Front => View::Front,
            ViewArg::Side => View::Side,
            ViewArg::Top => View::Top,
            ViewArg::Perspective => View::Perspective,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum UpArg {
    Y,
    Z,
}

impl From<UpArg> for Up {
    fn from(up: UpArg) -> Up {
        match up {
            UpArg::Y => Up::Y,
            UpArg::Z => Up::Z,
        }
    }
}

/// `640x480` → (640, 480).
pub fn parse_size(spec: &str) -> anyhow::Result<(usize, usize)> {
    let parsed = spec
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    match parsed {
        Some((w, h)) if (1..=16384).contains(&w) && (1..=16384).contains(&h) => Ok((w, h)),
        _ => usage!("--size '{spec}': expected WIDTHxHEIGHT, each 1 to 16384"),
    }
}

pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    if !activeskin::io::image::is_written(&args.output) {
        usage!(
            "'{}': renders must end in .exr or .png",
            args.output.display()
        );
    }
    let size = parse_size(&args.size)?;
    let (target, dx) = read_target(&args.input, args.grid.as_deref(), args.iso)?;
    let frame = target.bounds();
    let image = render::render(
        &*target,
        frame,
        (args.view.into(), args.up.into()),
        size,
        dx,
    );
    activeskin::io::image::write(&image, &args.output)
        .with_context(|| format!("rendering {}", args.input.display()))?;
    let hits = image.rgba.iter().filter(|p| p[3] > 0.0).count();
    println!(
        "{}: {}x{}, surface in {:.1} % of the pixels",
        args.output.display(),
        size.0,
        size.1,
        100.0 * hits as f64 / image.rgba.len() as f64
    );
    Ok(())
}
