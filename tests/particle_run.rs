//! The particle frame loop as a library, with or without OpenVDB (issue 28): the splash
//! sample dressed through `frames::ParticleRun` into OBJ meshes, clean on every frame;
//! with OpenVDB, byte for byte what `activeskin particles` writes for the same settings.
//! (`cargo test --no-default-features --test particle_run` runs it without the bridge.)

mod common;

use std::path::Path;

use activeskin::flow::Timing;
use activeskin::frames::{
    InputFrames, OutputSpec, Outputs, ParticleInput, ParticleRun, Progress, Report,
};
use activeskin::skin::{Physics, SkinParams, SpeedParams};
use activeskin::target::{fluid_iso, DEFAULT_SMOOTHING_LENGTH};

const DATA: &str = env!("CARGO_MANIFEST_DIR");
const RADIUS: f32 = 0.04;
const ALPHA: f32 = 48.0;

fn run_library(into: &Path) {
    // What a front end is told: the frames, each frame written with its measures, the end.
    let told = std::sync::Arc::new(std::sync::Mutex::new(Vec::<Report>::new()));
    let input = InputFrames::find(
        activeskin::field::Field::Particles,
        &format!("{DATA}/data/splash/drop.####.ply"),
        Some((1, 4)),
    )
    .unwrap();
    let dx = 0.5 * RADIUS;
    let particles = ParticleInput {
        radius: RADIUS,
        ignore_radii: false,
        smoothing_length: DEFAULT_SMOOTHING_LENGTH,
        iso: fluid_iso(DEFAULT_SMOOTHING_LENGTH),
        density_out: None,
        dx,
        velocity_scale: Some(1.0),

        attributes: Default::default(),
    };
    let spec = OutputSpec {
        out: None,
        mesh: Some(
            activeskin::sequence::FramePattern::parse(into.join("skin.####.obj").to_str().unwrap())
                .unwrap(),
        ),
        render: None,
        up: Default::default(),
        stats: None,
        resume: false,
        progress: Some(Progress {
            each: std::sync::Arc::new({
                let told = told.clone();
                move |report| told.lock().unwrap().push(*report)
            }),
            topology: true,
        }),
        stats_fields: Default::default(),
        reads: vec![input.pattern.clone()],
        side_outputs: Vec::new(),
        velocities: true,
        usd: None,
        surfaces: None,
        region: None,
        collider: None,
    };
    let mut outputs = Outputs::new(&spec, (1, 4)).unwrap();
    let run = ParticleRun {
        input: &input,
        particles: &particles,
        // The command's policy: a particle skin's defaults (its smoothing among them).
        params: Physics {
            alpha: ALPHA,
            ..Physics::default()
        }
        .particle_params(RADIUS, dx),
        fps: 24.0,
        timing: Timing::Mid,
        write_from: 1,
        hold_volume: true,
    };
    let mut notes = Vec::new();
    run.run(&mut outputs, &mut |line| notes.push(line)).unwrap();
    assert!(notes.is_empty(), "{notes:?}");
    let told = told.lock().unwrap();
    assert!(
        matches!(told[0], Report::Start { first: 1, last: 4 }),
        "{told:?}"
    );
    for (k, report) in told[1..5].iter().enumerate() {
        match *report {
            Report::Frame { frame, stats, .. } => {
                assert_eq!(frame, k as i64 + 1);
                // Asked for: one closed component.
                assert_eq!((stats.components, stats.euler_characteristic), (1, 2));
            }
            other => panic!("{other:?}"),
        }
    }
    assert!(matches!(told[5..], [Report::Done]), "{told:?}");
}

/// `activeskin particles` on the splash sample at the library run's radius, plus `extra`.
#[cfg(feature = "vdb")]
fn splash_command(extra: &[&str]) -> std::process::Output {
    let particles = format!("{DATA}/data/splash/drop.####.ply");
    let radius = RADIUS.to_string();
    let mut args = vec!["particles", "--particles", &particles, "--radius", &radius];
    args.extend_from_slice(extra);
    common::activeskin(&args)
}

#[test]
fn the_library_runs_particles_into_meshes() {
    let dir = common::scratch();
    run_library(dir.path());
    for frame in 1..=4 {
        let mesh =
            activeskin::io::obj::read(&dir.path().join(format!("skin.{frame:04}.obj"))).unwrap();
        let check = mesh.check();
        assert!(check.is_clean(), "frame {frame}: {check}");
        assert!(mesh.volume() > 0.0, "frame {frame}");
    }
    // The command line runs the same loop: the same bytes.
    #[cfg(feature = "vdb")]
    {
        let cli = common::scratch();
        let mesh = cli.path().join("skin.####.obj");
        let out = splash_command(&[
            "--alpha",
            &ALPHA.to_string(),
            "--frames",
            "1-4",
            "--mesh",
            mesh.to_str().unwrap(),
            "-q",
        ]);
        common::assert_ok(&out);
        for frame in 1..=4 {
            let name = format!("skin.{frame:04}.obj");
            let a = std::fs::read(dir.path().join(&name)).unwrap();
            let b = std::fs::read(cli.path().join(&name)).unwrap();
            assert!(a == b, "{name}: the library and the command differ");
        }
    }
}

/// `--stats` into a folder that does not exist yet is made, as `--mesh`'s is (it failed
/// after frame 1's mesh was written).
#[cfg(feature = "vdb")]
#[test]
fn the_stats_folder_is_made_like_the_others() {
    let dir = common::scratch();
    let stats = dir.path().join("new/deeper/stats.jsonl");
    let mesh = dir.path().join("meshes/skin.####.obj");
    let out = splash_command(&[
        "--frames",
        "1-2",
        "--mesh",
        mesh.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
        "-q",
    ]);
    common::assert_ok(&out);
    assert_eq!(common::stats_lines(&stats).len(), 2);
}

/// `--frames -3-2` as users type it (a negative first frame, no `=`): read as a range,
/// where clap took `-3` for an option; here frame -3 is not on disk, which is one line.
#[cfg(feature = "vdb")]
#[test]
fn a_negative_first_frame_is_a_range_not_an_option() {
    let dir = common::scratch();
    let mesh = dir.path().join("skin.####.obj");
    let out = splash_command(&["--frames", "-3-2", "--mesh", mesh.to_str().unwrap()]);
    common::assert_one_line_error(&out, "frame -3 of the particles is missing");
}

/// The policy every front end shares lives in the library: parameters checked by the
/// skin itself, the warm-up rule by the frame loop's inputs.
#[test]
fn the_library_checks_parameters_and_warms_up() {
    use activeskin::frames::auto_warmup;
    use activeskin::sequence::FramePattern;
    use activeskin::skin::{AnySkin, SkinError};
    use activeskin::target::Sphere;

    let sphere = Sphere {
        center: glam::Vec3::ZERO,
        radius: 0.5,
    };
    let dx = 0.05;
    let good = SkinParams {
        dx,
        speed: SpeedParams::default_for(dx, 4.0),
        ..SkinParams::default()
    };
    assert!(AnySkin::try_new(&sphere, good).is_ok());
    let refused = |params: SkinParams, field: &str| match AnySkin::try_new(&sphere, params).err() {
        Some(SkinError::Parameter { name, .. }) => assert_eq!(name.name(), field),
        other => panic!("{field}: {other:?}"),
    };
    let mut p = good;
    p.speed.alpha = f32::NAN;
    refused(p, "alpha");
    let mut p = good;
    p.speed.beta = -1.0;
    refused(p, "beta");
    let mut p = good;
    p.speed.volume_gain = f32::INFINITY;
    refused(p, "volume_gain");
    refused(SkinParams { dx: 0.0, ..good }, "voxel_size");
    refused(
        SkinParams {
            band_width: 1.0,
            ..good
        },
        "band_width",
    );
    refused(
        SkinParams {
            safety: 0.0,
            ..good
        },
        "safety",
    );
    for reach in [0.0, -1.0, f32::NAN] {
        let mut p = good;
        p.speed.reach = reach;
        refused(p, "reach");
    }
    let mut p = good;
    p.speed.reach = f32::INFINITY;
    assert!(p.check().is_ok());
    let message = SkinParams { dx: -1.0, ..good }
        .check()
        .unwrap_err()
        .to_string();
    assert_eq!(message, "`voxel_size` must be a positive number, got -1");

    // The frame loop refuses a frame rate it cannot advance by.
    for bad in [0.0, -24.0, f64::NAN, f64::INFINITY] {
        assert!(activeskin::frames::check_fps(bad).is_err(), "{bad}");
    }
    assert!(activeskin::frames::check_fps(24.0).is_ok());

    // ln(40)·fps/α frames: 23 at α 4 and 24 fps; none without attraction.
    assert_eq!(auto_warmup(4.0, 24.0), 23);
    assert_eq!(auto_warmup(0.0, 24.0), 0);
    // A warm-up starts earlier, never before the sequence's first frame.
    let mut input = InputFrames {
        pattern: FramePattern::parse("f.####.ply").unwrap(),
        existing: (3..=20).collect(),
        range: (10, 20),
    };
    assert_eq!(input.warm_up(4), 10);
    assert_eq!(input.range, (6, 20));
    let mut input = InputFrames {
        range: (10, 20),
        ..input
    };
    assert_eq!(input.warm_up(100), 10);
    assert_eq!(input.range, (3, 20));
}
