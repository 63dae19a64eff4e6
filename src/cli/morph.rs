//! `activeskin morph --from A --to B --frames 1-96 --out PATTERN [...]`: a skin started on
//! one shape and pointed at another.

use std::path::Path;

use activeskin::flow::Timing;
use activeskin::skin::AnySkin;
use activeskin::target::{Blobs, Sphere, Target, Torus, Union};
use glam::Vec3;

use super::args::{OutputArgs, PhysicsArgs};
use super::bad_usage;
use super::skin::{parse_frames, run_frames};
use activeskin::frames::read_target;
use activeskin::frames::FrameInput;
use activeskin::sequence::FramePattern;

#[derive(clap::Args)]
pub struct MorphArgs {
    /// Start shape: a VDB level-set file or a built-in shape (sphere:r=0.5,
    /// torus:R=0.6,r=0.25, blobs:fig7, blobs:fig6, spheres:fig7).
    #[arg(long)]
    from: String,
    /// Target shape, same forms as --from.
    #[arg(long)]
    to: String,
    /// Inclusive frame range, e.g. 1-96.
    #[arg(long, default_value = "1-48", allow_hyphen_values = true)]
    frames: String,
    #[command(flatten)]
    physics: PhysicsArgs,
    #[command(flatten)]
    outputs: OutputArgs,
}

/// A shape from the command line and the voxel size it suggests.
fn shape(spec: &str) -> anyhow::Result<(Box<dyn Target>, Option<f32>)> {
    let (kind, args) = spec.split_once(':').unwrap_or((spec, ""));
    // The parameters each analytic shape takes; any other is a typo, not a default.
    let keys: &[&str] = match kind {
        "sphere" => &["r"],
        "torus" => &["R", "r"],
        _ => &[],
    };
    let mut given: Vec<(&str, f32)> = Vec::new();
    if !keys.is_empty() {
        for pair in args.split(',').filter(|p| !p.is_empty()) {
            let (k, v) = pair
                .split_once('=')
                .ok_or_else(|| bad_usage(format!("'{spec}': expected key=value, got '{pair}'")))?;
            if !keys.contains(&k) {
                usage!("'{spec}': {kind} takes {}, not '{k}'", keys.join(", "));
            }
            let number: f32 = v
                .parse()
                .map_err(|_| bad_usage(format!("'{spec}': '{v}' is not a number")))?;
            if !(number.is_finite() && number > 0.0) {
                usage!("'{spec}': {k} must be a positive number, got {v}");
            }
            given.push((k, number));
        }
    }
    let value = |key: &str, default: f32| {
        given
            .iter()
            .rev()
            .find(|(k, _)| *k == key)
            .map_or(default, |&(_, v)| v)
    };
    let target: Box<dyn Target> = match kind {
        "sphere" => Box::new(Sphere {
            center: Vec3::ZERO,
            radius: value("r", 0.5),
        }),
        "torus" => {
            let (major, minor) = (value("R", 0.6), value("r", 0.25));
            if minor >= major {
                usage!("'{spec}': a torus needs r < R (r {minor}, R {major})");
            }
            Box::new(Torus {
                center: Vec3::ZERO,
                major,
                minor,
            })
        }
        "blobs" if args == "fig7" => Box::new(Blobs::fig7_points()),
        "blobs" if args == "fig6" => Box::new(Blobs::fig6_twisted_segment()),
        "spheres" if args == "fig7" => Box::new(Union::fig7_spheres()),
        _ if Path::new(spec).extension().is_some_and(|e| e == "vdb") => {
            let (target, dx) = read_target(Path::new(spec), None, None)?;
            return Ok((target, Some(dx)));
        }
        _ => usage!("'{spec}': not a .vdb file or a built-in shape (sphere:r=R, torus:R=A,r=B, blobs:fig7, blobs:fig6, spheres:fig7)"),
    };
    Ok((target, None))
}

pub fn run(args: &MorphArgs) -> anyhow::Result<()> {
    if args.physics.warmup.is_some() {
        usage!("--warmup is for skin and particles: a morph starts on its --from shape");
    }
    let range = parse_frames(&args.frames)?;
    let (from, from_dx) = shape(&args.from)?;
    let (to, to_dx) = shape(&args.to)?;
    let params = args
        .physics
        .params(from_dx.or(to_dx).unwrap_or(1.0 / 32.0))?;
    let skin = AnySkin::try_new(&*from, params)?;
    skin.check_target(&*to)?;
    let to = &to;
    run_frames(
        range,
        range.0,
        skin,
        (args.physics.fps, Timing::Start),
        &args.outputs,
        // The shapes read from files.
        [&args.from, &args.to]
            .into_iter()
            .filter(|s| Path::new(s).is_file())
            .map(|s| FramePattern::held(s))
            .collect(),
        |_| Ok(FrameInput::target(Box::new(to))),
    )
}
