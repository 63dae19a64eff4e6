//! `activeskin demo [--out DIR]`: the built-in demo, no input needed — the Fig. 7 morph
//! (six point skeletons → a pair of spheres: a filament, then a split), a skin carried by
//! the known motion of a target that orbits and swells (§7), and a skin dressing a
//! splashing drop of particles (§6.1), each as VDB, OBJ, EXR and stats sequences.

use std::path::{Path, PathBuf};

use activeskin::flow::{Flow, Rigid, Timing};
use activeskin::frames::{Cover, Spray};
use activeskin::grid::Aabb;
use activeskin::io::ply;
use activeskin::particles::splash;
use activeskin::skin::AnySkin;
use activeskin::target::{iso_for_radius, Blobs, Density, Sphere, Target, Union};
use glam::Vec3;

use super::args::{OutputArgs, PhysicsArgs, PrecisionArg};
use super::skin::run_frames;
use activeskin::frames::FrameInput;

#[derive(clap::Args)]
pub struct DemoArgs {
    /// Folder to write into.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// No progress output.
    #[arg(long, short)]
    quiet: bool,
}

fn outputs(dir: &Path, name: &str, quiet: bool) -> OutputArgs {
    let file = |ext: &str| {
        dir.join(format!("{name}/{name}.####.{ext}"))
            .to_string_lossy()
            .into_owned()
    };
    OutputArgs {
        out: Some(file("vdb")),
        mesh: Some(file("obj")),
        render: Some(file("exr")),
        render_size: "480x270".into(),
        up: super::render::UpArg::Y,
        stats: Some(dir.join(format!("{name}/stats.jsonl"))),
        resume: false,
        quiet,
        velocities: true,
        // The same meshes as one shot, for Houdini, Blender and Maya to open.
        usd: Some(dir.join(format!("{name}/{name}.usda"))),
        meters_per_unit: 1.0,
        shot_frames: None,
        region: None,
        collider: None,
        collider_gap: None,
        collider_depth: 0.0,
    }
}

fn physics(alpha: f32, beta: f32) -> PhysicsArgs {
    PhysicsArgs {
        fps: 24.0,
        alpha,
        beta: Some(beta),
        volume_gain: 0.0,
        area_gain: 0.0,
        voxel_size: None,
        precision: PrecisionArg::F32,
        smooth: None,
        warmup: None,
    }
}

/// A sphere orbiting the origin in the xy plane, its radius breathing.
struct Orbiting {
    time: f32,
}

impl Orbiting {
    fn sphere(&self) -> Sphere {
        let angle = std::f32::consts::TAU * self.time / 2.0;
        Sphere {
            center: Vec3::new(0.4 * angle.cos(), 0.4 * angle.sin(), 0.0),
            radius: 0.3 + 0.05 * (std::f32::consts::TAU * self.time).sin(),
        }
    }
}

/// The orbit's motion: half a turn a second about the z axis, plus the breathing along
/// the sphere's normals.
impl Flow for Orbiting {
    fn velocity(&self, p: Vec3) -> Vec3 {
        let turn = Rigid {
            center: Vec3::ZERO,
            linear: Vec3::ZERO,
            angular: Vec3::new(0.0, 0.0, std::f32::consts::PI),
        };
        let tau = std::f32::consts::TAU;
        let breathing = 0.05 * tau * (tau * self.time).cos();
        turn.velocity(p) + breathing * (p - self.sphere().center).normalize_or_zero()
    }
}

impl Target for Orbiting {
    fn distance(&self, p: Vec3) -> f32 {
        self.sphere().distance(p)
    }
    fn bounds(&self) -> Aabb {
        self.sphere().bounds()
    }
}

/// Names the sequence whose frame lines follow, unless quiet.
fn announce(args: &DemoArgs, name: &str, what: &str) {
    if !args.quiet {
        println!("{name} ({}): {what}", args.out.join(name).display());
    }
}

pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    let dx = 1.0 / 32.0;

    let fig7 = physics(4.0, 0.001);
    let skin = AnySkin::new(&Blobs::fig7_points(), fig7.params(dx)?);
    let spheres = Union::fig7_spheres();
    let out = outputs(&args.out, "fig7", args.quiet);
    announce(
        args,
        "fig7",
        "the paper's Fig. 7, six blobs pulled onto two spheres, 48 frames",
    );
    run_frames(
        (1, 48),
        1,
        skin,
        (fig7.fps, Timing::Start),
        &out,
        Vec::new(),
        |_| Ok(FrameInput::target(Box::new(&spheres))),
    )?;

    // The orbit's motion is known: the skin is carried by it (§7), α = 4 corrects.
    let moving = physics(4.0, 0.0005);
    let skin = AnySkin::new(&Orbiting { time: 0.0 }, moving.params(dx)?);
    let out = outputs(&args.out, "orbit", args.quiet);
    announce(
        args,
        "orbit",
        "a breathing sphere orbiting, carried by its motion, 48 frames",
    );
    // An analytic velocity, exact at each frame: the mean of both ends is second order.
    run_frames(
        (1, 48),
        1,
        skin,
        (moving.fps, Timing::Mid),
        &out,
        Vec::new(),
        |frame| {
            let time = (frame - 1) as f32 / 24.0;
            Ok(FrameInput {
                target: Box::new(Orbiting { time }),
                flow: Some(Box::new(Orbiting { time })),
                carried: None,
                seed: false,
                volume: None,
                attributes: None,
                spray: Spray::default(),
                cover: Cover::default(),
            })
        },
    )?;

    // The drop of data/splash (same animation), its particles written alongside.
    let mut drop = splash::Splash::new();
    let clouds: Vec<Vec<Vec3>> = (0..36)
        .map(|_| {
            let cloud = drop.positions().to_vec();
            drop.advance(1.0 / 24.0);
            cloud
        })
        .collect();
    let radius = splash::SPACING;
    let h = 2.0 * radius;
    let iso = iso_for_radius(radius, h);
    let liquid = physics(48.0, 0.0003);
    let density = |frame: i64| Density::new(clouds[frame as usize - 1].clone(), h, iso);
    let skin = AnySkin::new(&density(1), liquid.particle_params(radius, 0.5 * radius)?);
    std::fs::create_dir_all(args.out.join("splash"))?;
    for (frame, cloud) in (1..).zip(&clouds) {
        let path = args.out.join(format!("splash/particles.{frame:04}.ply"));
        ply::write_ply(&path, cloud)?;
    }
    let out = outputs(&args.out, "splash", args.quiet);
    announce(
        args,
        "splash",
        "a drop of particles splashing on a floor, 36 frames",
    );
    run_frames(
        (1, clouds.len() as i64),
        1,
        skin,
        (liquid.fps, Timing::Start),
        &out,
        // The demo writes its particles itself, before the run.
        Vec::new(),
        |frame| {
            Ok(FrameInput {
                target: Box::new(density(frame)),
                flow: None,
                carried: None,
                seed: true,
                volume: None,
                attributes: None,
                spray: Spray::default(),
                cover: Cover::default(),
            })
        },
    )?;

    let shown = args.out.display();
    println!("wrote {shown}/fig7/fig7.####.{{vdb,obj,exr}}, {shown}/orbit/orbit.####.{{vdb,obj,exr}} and {shown}/splash/splash.####.{{vdb,obj,exr}} (its particles in splash/particles.####.ply), with stats.jsonl in each");
    println!("look at them: Houdini File SOP on {shown}/fig7/fig7.$F4.vdb, Blender Import > OpenVDB (sequence)");
    Ok(())
}
