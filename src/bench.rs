//! `activeskin bench [--json]`: ours and OpenVDB in one process, on the same input, as
//! ratios (these machines are too noisy for absolute times to compare across runs).

mod formats;
mod outputs;
mod particles;
mod pool;
mod scale;
mod sph;

use std::time::Instant;

use activeskin::grid::Fixed16;
use activeskin::grid::IndexToWorld;
use activeskin::grid::SparseGrid;
use activeskin::mesh::Mesh;
use activeskin::polygonize::{Crossings, Polygonizer};
use activeskin::skin::{Skin, SkinParams, SpeedParams};
use activeskin::target::{sample, Blobs, Sphere, Target, Torus, Union};
use activeskin::validate;
use activeskin::vdb::Grid;
use anyhow::Context;
use glam::Vec3;
use serde_json::json;

/// Where a bench's data or tools are kept once made: the folder named by the environment
/// variable `variable` when given and set, else `activeskin/{folder}` in the user's cache
/// (XDG_CACHE_HOME or ~/.cache).
fn cache_dir(variable: Option<&str>, folder: &str) -> Option<std::path::PathBuf> {
    if let Some(dir) = variable.and_then(std::env::var_os) {
        return Some(dir.into());
    }
    std::env::var_os("XDG_CACHE_HOME")
        .map(std::path::PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| std::path::PathBuf::from(h).join(".cache")))
        .map(|c| c.join("activeskin").join(folder))
}

/// Runs `command`, failing with its stderr; returns the wall time in seconds.
fn timed(command: &mut std::process::Command) -> anyhow::Result<f64> {
    let start = std::time::Instant::now();
    let output = command
        .output()
        .with_context(|| format!("cannot run {command:?}"))?;
    if !output.status.success() {
        anyhow::bail!(
            "{command:?} failed: {}",
            String::from_utf8_lossy(&output.stderr).trim()
        );
    }
    Ok(start.elapsed().as_secs_f64())
}

#[derive(clap::Args)]
pub struct BenchArgs {
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
    /// Also run the largest scaling case (n = 1024: a sphere of radius 256 voxels).
    #[arg(long)]
    full: bool,
    /// Also race splashsurf on particles: a SPlisHSPlasH dam break in motion (baked once
    /// into ~/.cache/activeskin/sph, or ACTIVESKIN_SPH_CACHE, with pysplishsplash; skipped
    /// when it cannot be) and a smoothly twisting ellipsoid of particles (whose true
    /// surface is smooth in time), time, volume, particles outside, temporal noise and flicker,
    /// and the look (bumps, pieces, single-layer sheets) beside splashsurf smoothed as its
    /// README recommends; a settled pool's facet tilt and top; 100 k and 1 M particles at
    /// rest, ms per frame; distance to the true surface and
    /// flicker on a fluid at rest. splashsurf is installed into the cache folder with
    /// cargo when not found.
    #[arg(long)]
    particles: bool,
    /// Only the particle races (with --particles).
    #[arg(long, requires = "particles")]
    particles_only: bool,
    /// Only the races in motion, the two dam breaks, the smooth twist and the settled
    /// pool (with --particles-only): for trying settings against splashsurf.
    #[arg(long, requires = "particles_only")]
    sph_only: bool,
    /// Extra options for our `particles` runs in motion, e.g. "--alpha 16" (with
    /// --particles): the same race and measures for other settings.
    #[arg(long, requires = "particles", allow_hyphen_values = true)]
    sph_args: Option<String>,
    /// Also race each shot in motion at twice its frame rate (with --particles): the dam
    /// break baked once more at 48 fps (its every other frame is the 24 fps shot of the
    /// same simulation) and the twist at 48 fps. A tool's own flicker does not depend on
    /// the frame rate; what the liquid's motion adds to the measures halves with the
    /// frame interval.
    #[arg(long, requires = "particles")]
    frame_rates: bool,
    /// The splashsurf binary to race (default: on the PATH, or in ~/.cache/activeskin).
    #[arg(long)]
    splashsurf: Option<std::path::PathBuf>,
    /// Only the time to read a 1 M-particle frame in every particle format (written once
    /// by data/formats/write_frames.py, pip vtk and numpy, into ~/.cache/activeskin/formats
    /// or ACTIVESKIN_FORMATS_CACHE), against our PLY reader.
    #[arg(long, conflicts_with = "particles")]
    formats: bool,
    /// Only what the render-ready outputs cost at 1 M particles in motion: PLY meshes
    /// with velocities and attributes against without, and the USD frame layer's writer
    /// against the OBJ writer.
    #[arg(long, conflicts_with_all = ["particles", "formats"])]
    outputs: bool,
    /// Only the scale race: moving liquids of --scale-millions particles generated with
    /// velocities and ids, ours against splashsurf on its best input (float x y z),
    /// whole-process time and peak memory, our frames' times and band nodes.
    #[arg(long, conflicts_with_all = ["particles", "formats", "outputs"])]
    scale: bool,
    /// The scale race's sizes, millions of particles.
    #[arg(
        long,
        requires = "scale",
        value_delimiter = ',',
        default_value = "1,4,10"
    )]
    scale_millions: Vec<f64>,
    /// Seconds each side of the morph-to-accuracy race may run before it is called.
    #[arg(long, default_value_t = 30.0)]
    race_cap: f64,
}

fn sphere(radius: f32) -> Sphere {
    Sphere {
        center: Vec3::ZERO,
        radius,
    }
}

fn params(dx: f32) -> SkinParams {
    SkinParams {
        dx,
        speed: SpeedParams {
            alpha: 2.0,
            beta: 0.001 * dx / 0.01,
            ..SpeedParams::default()
        },
        ..SkinParams::default()
    }
}

/// Seconds per step and band nodes of our skin on a sphere of `voxels` radius moving
/// toward one 4 % larger.
fn our_step(voxels: f32, steps: usize) -> (f64, f64) {
    let dx = 1.0 / voxels;
    let mut skin: Skin<f32> = Skin::new(&sphere(1.0), params(dx));
    let target = sphere(1.04);
    let dt = skin.stable_dt(&target);
    skin.step(&target, dt);
    let mut nodes = 0usize;
    let start = std::time::Instant::now();
    for _ in 0..steps {
        nodes += skin.grid().active_node_count();
        skin.step(&target, dt);
    }
    let seconds = start.elapsed().as_secs_f64() / steps as f64;
    (seconds, nodes as f64 / steps as f64)
}

/// [`our_step`] with the skin carried by a flow as well (§7): a glide of half a voxel a
/// sub-step along a diagonal, each sub-step advection, speed, update, upkeep and
/// polygonization (the tube then reaches the band's 26 neighbours).
fn our_step_in_flow(voxels: f32, steps: usize) -> (f64, f64) {
    let dx = 1.0 / voxels;
    let mut skin: Skin<f32> = Skin::new(&sphere(1.0), params(dx));
    let target = sphere(1.04);
    let dt = skin.stable_dt(&target);
    let flow = activeskin::flow::Rigid {
        center: Vec3::ZERO,
        linear: Vec3::new(1.0, 0.6, 0.3).normalize() * (0.5 * dx / dt),
        angular: Vec3::ZERO,
    };
    skin.advance_in_flow(&target, Some(&flow), f64::from(dt));
    // Five sub-steps a call: the statistics an advance ends with (components, Euler
    // characteristic) are a frame's cost, not a step's.
    let (mut nodes, mut substeps) = (0usize, 0u32);
    let start = std::time::Instant::now();
    for _ in 0..steps.div_ceil(5) {
        let before = skin.grid().active_node_count();
        let stats = skin.advance_in_flow(&target, Some(&flow), f64::from(5.0 * dt));
        nodes += before * stats.substeps as usize;
        substeps += stats.substeps;
    }
    let seconds = start.elapsed().as_secs_f64() / f64::from(substeps);
    (seconds, nodes as f64 / f64::from(substeps))
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let mut report = serde_json::Map::new();
    let mut lines = Vec::new();
    if args.formats {
        formats::run(&mut lines, &mut report)?;
    } else if args.outputs {
        outputs::run(&mut lines, &mut report)?;
    } else if args.scale {
        scale::run(
            args.splashsurf.as_deref(),
            &args.scale_millions,
            &mut lines,
            &mut report,
        )?;
    } else if !args.particles_only {
        solver_races(args, &mut lines, &mut report)?;
    }
    if args.particles {
        particles::run(
            args.splashsurf.as_deref(),
            particles::Races {
                at_rest: !args.sph_only,
                sph_args: args.sph_args.as_deref().unwrap_or(""),
                frame_rates: args.frame_rates,
            },
            &mut lines,
            &mut report,
        )?;
    }
    if args.json {
        println!("{}", serde_json::Value::Object(report));
    } else {
        for line in lines {
            println!("{line}");
        }
    }
    Ok(())
}

/// What a race adds to the report: a line to print, a JSON entry.
type Report = serde_json::Map<String, serde_json::Value>;

/// Ours against OpenVDB: step, meshing, memory, scaling, morph races, advection, flicker.
fn solver_races(
    args: &BenchArgs,
    lines: &mut Vec<String>,
    report: &mut Report,
) -> anyhow::Result<()> {
    // A sphere of r = 100 voxels: the step, meshing and memory races' level set.
    let dx = 0.01f32;
    let source = Grid::level_set_sphere(1.0, [0.0; 3], dx, 3.0)?;
    step_race(&source, dx, lines, report)?;
    meshing_race(&source, dx, lines, report)?;
    memory_race(&source, dx, lines, report);
    scaling(args, lines, report)?;
    morph_races(args, lines, report)?;
    advection_race_line(lines, report)?;
    flicker_line(lines, report);
    Ok(())
}

/// One step of ours against one CFL iteration of LevelSetMorphing, then ours with a
/// velocity.
fn step_race(
    source: &Grid,
    dx: f32,
    lines: &mut Vec<String>,
    report: &mut Report,
) -> anyhow::Result<()> {
    // Per-step throughput, r = 100 voxels: one full step of ours (speed, update, upkeep,
    // renormalisation, polygonization) against one CFL iteration of LevelSetMorphing.
    let (our_seconds, our_nodes) = our_step(100.0, 10);
    let target = Grid::level_set_sphere(1.04, [0.0; 3], dx, 3.0)?;
    let morph = source.morph_timing(&target, 0.2)?;
    let their_seconds = morph.seconds / morph.iterations.max(1) as f64;
    let ours_rate = our_nodes / our_seconds;
    let theirs_rate = morph.active_voxels as f64 / their_seconds;
    report.insert(
        "step".into(),
        json!({"ours_band_nodes_per_s": ours_rate, "openvdb_active_voxels_per_s": theirs_rate,
               "ours_ms": our_seconds * 1e3, "openvdb_ms_per_iteration": their_seconds * 1e3,
               "openvdb_iterations": morph.iterations, "ratio": ours_rate / theirs_rate}),
    );
    lines.push(format!(
        "step, sphere r = 100 voxels     ours {:.2} M nodes/s ({:.0} ms)   OpenVDB morph {:.2} M voxels/s ({:.0} ms/iteration)   ratio {:.2}×",
        ours_rate / 1e6, our_seconds * 1e3, theirs_rate / 1e6, their_seconds * 1e3, ours_rate / theirs_rate
    ));

    let (flow_seconds, flow_nodes) = our_step_in_flow(100.0, 10);
    report.insert(
        "step_with_velocity".into(),
        json!({"ours_band_nodes_per_s": flow_nodes / flow_seconds, "ours_ms": flow_seconds * 1e3,
               "band_nodes": flow_nodes, "against_velocity_off": our_seconds / flow_seconds}),
    );
    lines.push(format!(
        "step with velocity, same sphere ours {:.2} M nodes/s ({:.0} ms, {:.2} M nodes: the tube reaches 26 neighbours)   {:.2}× the step without",
        flow_nodes / flow_seconds / 1e6, flow_seconds * 1e3, flow_nodes / 1e6, our_seconds / flow_seconds
    ));

    Ok(())
}

/// Our polygonizer against volumeToMesh on `source`.
fn meshing_race(
    source: &Grid,
    dx: f32,
    lines: &mut Vec<String>,
    report: &mut Report,
) -> anyhow::Result<()> {
    // Meshing the same band: our polygonizer on the level set imported into our blocks
    // (import untimed), against volumeToMesh on the OpenVDB grid; each side's second run is
    // timed (our buffers are reused from frame to frame).
    let data = source.to_data()?;
    let scale = data.background;
    let mut band: SparseGrid<f32> = SparseGrid::from_vdb(&data, |phi| phi / scale);
    activeskin::grid::tube::upkeep(&mut band);
    let xf = IndexToWorld {
        origin: Vec3::ZERO,
        dx,
    };
    let (mut polygonizer, mut mesh, mut crossings) = (
        Polygonizer::default(),
        Mesh::default(),
        Crossings::default(),
    );
    let mut ours_mesh_s = 0.0;
    let mut theirs_mesh_s = 0.0;
    let mut theirs_polygons = 0;
    for _ in 0..2 {
        let start = std::time::Instant::now();
        polygonizer.run(&band, xf, &mut mesh, &mut crossings);
        ours_mesh_s = start.elapsed().as_secs_f64();
        let start = std::time::Instant::now();
        let theirs = source.volume_to_mesh(0.0, 0.0)?;
        theirs_mesh_s = start.elapsed().as_secs_f64();
        theirs_polygons = theirs.triangles.len() / 3 + theirs.quads.len() / 4;
    }
    report.insert(
        "meshing".into(),
        json!({"ours_ms": ours_mesh_s * 1e3, "openvdb_ms": theirs_mesh_s * 1e3,
               "ours_triangles": mesh.triangles.len(), "openvdb_polygons": theirs_polygons,
               "speedup": theirs_mesh_s / ours_mesh_s}),
    );
    lines.push(format!(
        "meshing, same level set         ours {:.1} ms   volumeToMesh {:.1} ms   speed-up {:.2}×",
        ours_mesh_s * 1e3,
        theirs_mesh_s * 1e3,
        theirs_mesh_s / ours_mesh_s
    ));

    Ok(())
}

/// Our skin's bytes against OpenVDB's grid's.
fn memory_race(source: &Grid, dx: f32, lines: &mut Vec<String>, report: &mut Report) {
    // Memory of the same skin, after a few steps of growth toward a larger sphere: the
    // arena's spare capacity is counted as it is during a run.
    fn settled<P: activeskin::grid::Potential>(dx: f32) -> usize {
        let mut skin = Skin::<P>::new(&sphere(1.0), params(dx));
        let target = sphere(1.04);
        let dt = skin.stable_dt(&target);
        for _ in 0..3 {
            skin.step(&target, dt);
        }
        skin.memory_bytes()
    }
    let f32_bytes = settled::<f32>(dx);
    let fixed_bytes = settled::<Fixed16>(dx);
    let vdb_bytes = source.mem_usage();
    report.insert(
        "memory".into(),
        json!({"ours_f32_bytes": f32_bytes, "ours_fixed16_bytes": fixed_bytes, "openvdb_bytes": vdb_bytes,
               "ratio_f32": f32_bytes as f64 / vdb_bytes as f64, "ratio_fixed16": fixed_bytes as f64 / vdb_bytes as f64}),
    );
    lines.push(format!(
        "memory, sphere r = 100 voxels   ours f32 {:.1} MB, fixed16 {:.1} MB   OpenVDB {:.1} MB   ratios {:.2}×, {:.3}×",
        f32_bytes as f64 / 1e6, fixed_bytes as f64 / 1e6, vdb_bytes as f64 / 1e6,
        f32_bytes as f64 / vdb_bytes as f64, fixed_bytes as f64 / vdb_bytes as f64
    ));
}

/// Our step's cost against the sphere's size (area: exponent 2), and against one thread.
fn scaling(args: &BenchArgs, lines: &mut Vec<String>, report: &mut Report) -> anyhow::Result<()> {
    let threads = rayon::current_num_threads();
    // Scaling with the sphere's size: cost ∝ area gives exponent 2 in n.
    let mut sizes = vec![128.0f64, 256.0, 512.0];
    if args.full {
        sizes.push(1024.0);
    }
    let mut points = Vec::new();
    for &n in &sizes {
        let (seconds, nodes) = our_step((n / 4.0) as f32, 3);
        points.push((n, seconds, nodes));
    }
    let exponent = fit_exponent(&points.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>());
    let serial = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()?
        .install(|| our_step(64.0, 3).0);
    let parallel = our_step(64.0, 3).0;
    report.insert(
        "scaling".into(),
        json!({"n": sizes, "ms": points.iter().map(|p| p.1 * 1e3).collect::<Vec<_>>(),
               "band_nodes": points.iter().map(|p| p.2).collect::<Vec<_>>(), "exponent": exponent,
               "threads": threads, "speedup_over_1_thread": serial / parallel}),
    );
    for (n, seconds, nodes) in &points {
        lines.push(format!(
            "scaling, n = {n:<5} (r = n/4)      {:.1} ms/step, {:.2} M band nodes",
            seconds * 1e3,
            nodes / 1e6
        ));
    }
    lines.push(format!(
        "scaling exponent {exponent:.2} (area: 2)   {threads} threads vs 1: {:.2}×",
        serial / parallel
    ));

    Ok(())
}

/// Morphs to accuracy, ours against LevelSetMorphing.
fn morph_races(
    args: &BenchArgs,
    lines: &mut Vec<String>,
    report: &mut Report,
) -> anyhow::Result<()> {
    // Morph to accuracy: β = 0 on both sides, then with tension (OpenVDB's mean-curvature
    // filter interleaved at the same rate).
    let torus = Torus {
        center: Vec3::ZERO,
        major: 0.6,
        minor: 0.25,
    };
    let cases: [(&str, &dyn Target, &dyn Target, f32); 3] = [
        ("sphere → torus", &sphere(0.7), &torus, 0.0),
        (
            "Fig. 7 blobs → spheres",
            &Blobs::fig7_points(),
            &Union::fig7_spheres(),
            0.0,
        ),
        (
            "sphere → torus, β 0.002",
            &sphere(0.7),
            &torus,
            RACE_TENSION,
        ),
    ];
    let mut races = Vec::new();
    for (name, start, target, beta) in cases {
        let r = race(start, target, 1.0 / 32.0, beta, args.race_cap)?;
        let shown =
            |t: Option<f64>| t.map_or(format!("> {:.0} s", args.race_cap), |t| format!("{t:.2} s"));
        let ratio = match (r.ours, r.openvdb) {
            (Some(a), Some(b)) => format!("{:.1}×", b / a),
            (Some(_), None) => format!("> {:.1}×", args.race_cap / r.ours.unwrap_or(1.0)),
            _ => "—".into(),
        };
        lines.push(format!(
            "morph to 0.1 / 0.5 voxel, {name:<24} ours {}   OpenVDB {}   speed-up {ratio}",
            shown(r.ours),
            shown(r.openvdb)
        ));
        races.push(
            json!({"case": name, "beta": beta, "ours_s": r.ours, "openvdb_s": r.openvdb, "cap_s": args.race_cap}),
        );
    }
    report.insert("morph_to_accuracy".into(), json!(races));

    Ok(())
}

/// [`advection_race`] reported.
fn advection_race_line(lines: &mut Vec<String>, report: &mut Report) -> anyhow::Result<()> {
    // Advection (§7): one turn of a sphere, ours against OpenVDB's LevelSetAdvection.
    let turn = advection_race()?;
    lines.push(format!(
        "advection, one turn of a sphere (8 voxels)   ours {:.2} s, volume {:+.2} %, {:.3} voxel off   OpenVDB {:.2} s, volume {:+.2} %, {:.3} voxel off   speed-up {:.1}×",
        turn.ours_s, turn.ours_volume_pct, turn.ours_off, turn.openvdb_s, turn.openvdb_volume_pct,
        turn.openvdb_off, turn.openvdb_s / turn.ours_s
    ));
    report.insert(
        "advection".into(),
        json!({"ours_s": turn.ours_s, "openvdb_s": turn.openvdb_s, "speedup": turn.openvdb_s / turn.ours_s,
               "ours_volume_pct": turn.ours_volume_pct, "openvdb_volume_pct": turn.openvdb_volume_pct,
               "ours_mean_voxels_off": turn.ours_off, "openvdb_mean_voxels_off": turn.openvdb_off,
               "ours_substeps": turn.ours_steps, "openvdb_iterations": turn.openvdb_steps}),
    );

    Ok(())
}

/// The skin against per-frame surfacing on a jittered static cloud.
fn flicker_line(lines: &mut Vec<String>, report: &mut Report) {
    // Temporal quality on a jittered static cloud: the skin against per-frame surfacing.
    let f = activeskin::measure::flicker::jittered_ball(0.05, 0.3, 16, 4.0);
    report.insert(
        "flicker".into(),
        json!({"skin_voxels": f.skin, "per_frame_voxels": f.per_frame, "gain": f.per_frame / f.skin,
               "skin_error_voxels": f.skin_error, "per_frame_error_voxels": f.per_frame_error}),
    );
    lines.push(format!(
        "flicker, jittered static cloud   skin {:.3} voxel/frame   per-frame surfacing {:.3}   {:.1}× less (error {:.3} vs {:.3} voxel)",
        f.skin, f.per_frame, f.per_frame / f.skin, f.skin_error, f.per_frame_error
    ));
}

/// One turn of the advection race.
struct Turn {
    ours_s: f64,
    openvdb_s: f64,
    ours_volume_pct: f64,
    openvdb_volume_pct: f64,
    ours_off: f64,
    openvdb_off: f64,
    ours_steps: u64,
    openvdb_steps: u64,
}

/// A sphere of radius 0.25 at Δx = 1/32 (8 voxels), 0.3 off the z axis, carried once
/// round in 2 s (48 frames of 1/24 s) by each side with no attraction or tension; volume
/// change against the start and mean distance of the final surface to the exact sphere.
fn advection_race() -> anyhow::Result<Turn> {
    use activeskin::flow::Rigid;
    let dx = 1.0f32 / 32.0;
    let start = Sphere {
        center: Vec3::new(0.3, 0.0, 0.0),
        radius: 0.25,
    };
    let omega = std::f32::consts::PI;
    let motion = Rigid {
        center: Vec3::ZERO,
        linear: Vec3::ZERO,
        angular: Vec3::new(0.0, 0.0, omega),
    };
    let mut skin: Skin<f32> = Skin::new(
        &start,
        SkinParams {
            dx,
            speed: SpeedParams {
                alpha: 0.0,
                beta: 0.0,
                ..SpeedParams::default()
            },
            ..SkinParams::default()
        },
    );
    let volume0 = skin.stats().volume;
    let mut steps = 0u64;
    let clock = Instant::now();
    for _ in 0..48 {
        steps += u64::from(
            skin.advance_in_flow(&start, Some(&motion), 1.0 / 24.0)
                .substeps,
        );
    }
    let ours_s = clock.elapsed().as_secs_f64();
    let ours_volume_pct = 100.0 * (skin.stats().volume - volume0) / volume0;
    let ours_off = accuracy(&skin.mesh().positions, &start, dx).0;

    let mut grid = Grid::level_set_sphere(0.25, [0.3, 0.0, 0.0], dx, 3.0)?;
    let theirs0 = grid.measure_level_set()?.volume;
    let (mut openvdb_s, mut openvdb_steps) = (0.0, 0u64);
    for _ in 0..48 {
        let t = grid.advect_rotation(f64::from(omega), 1.0 / 24.0)?;
        openvdb_s += t.seconds;
        openvdb_steps += t.iterations;
    }
    let openvdb_volume_pct = 100.0 * (grid.measure_level_set()?.volume - theirs0) / theirs0;
    let theirs = validate::openvdb_mesh(&grid)?;
    let openvdb_off = accuracy(&theirs.positions, &start, dx).0;
    Ok(Turn {
        ours_s,
        openvdb_s,
        ours_volume_pct,
        openvdb_volume_pct,
        ours_off,
        openvdb_off,
        ours_steps: steps,
        openvdb_steps,
    })
}

/// Mean and max distance of mesh vertices to `target`, voxels.
fn accuracy(positions: &[Vec3], target: &dyn Target, dx: f32) -> (f64, f64) {
    let d: Vec<f64> = positions
        .iter()
        .map(|&p| f64::from(target.distance(p).abs() / dx))
        .collect();
    let mean = d.iter().sum::<f64>() / d.len().max(1) as f64;
    (mean, d.iter().copied().fold(0.0, f64::max))
}

struct Race {
    ours: Option<f64>,
    openvdb: Option<f64>,
}

/// The race's attraction gain α.
const RACE_ALPHA: f32 = 12.0;
/// The race's tension: its equilibrium offset βκ/α stays under 0.03 voxel on the torus.
const RACE_TENSION: f32 = 0.002;

/// Wall time (accuracy checks excluded) until a skin started on `start` is within 0.1
/// voxel of `target` on average and 0.5 voxel at most; `None` past `cap` seconds.
///
/// LevelSetMorphing moves the surface at the level-set difference (α = 1 in its own
/// time), so its time τ is ours times α. With tension, each of OpenVDB's
/// mean-curvature iterations moves the surface by κ·Δx²/6 (κ = κ₁+κ₂), which is our
/// β·κ·t for t = Δx²/(6β): 6βΔτ/(αΔx²) iterations are owed per morph advance Δτ.
fn race(
    start: &dyn Target,
    target: &dyn Target,
    dx: f32,
    beta: f32,
    cap: f64,
) -> anyhow::Result<Race> {
    let reached = |(mean, max): (f64, f64)| mean <= 0.1 && max <= 0.5;
    let mut skin: Skin<f32> = Skin::new(
        start,
        SkinParams {
            dx,
            speed: SpeedParams {
                alpha: RACE_ALPHA,
                beta,
                ..SpeedParams::default()
            },
            ..SkinParams::default()
        },
    );
    let mut ours = None;
    let mut elapsed = 0.0;
    while elapsed < cap {
        let clock = Instant::now();
        skin.advance(target, 1.0 / 24.0);
        elapsed += clock.elapsed().as_secs_f64();
        if reached(accuracy(&skin.mesh().positions, target, dx)) {
            ours = Some(elapsed);
            break;
        }
    }
    let mut grid = Grid::from_data(&sample::level_set(start, dx, 3.0))?;
    let goal = Grid::from_data(&sample::level_set(target, dx, 3.0))?;
    let mut openvdb = None;
    let mut elapsed = 0.0;
    let advance = f64::from(4.0 * dx);
    let iterations_per_advance = 6.0 * f64::from(beta) * advance / f64::from(RACE_ALPHA * dx * dx);
    let mut owed = 0.0;
    while elapsed < cap {
        elapsed += grid.morph_advance(&goal, advance)?.seconds;
        owed += iterations_per_advance;
        if owed >= 1.0 {
            elapsed += grid.mean_curvature_flow(owed as u32)?.seconds;
            owed = owed.fract();
        }
        let mesh = validate::openvdb_mesh(&grid)?;
        if reached(accuracy(&mesh.positions, target, dx)) {
            openvdb = Some(elapsed);
            break;
        }
    }
    Ok(Race { ours, openvdb })
}

/// Least-squares slope of log(time) against log(n).
fn fit_exponent(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points.iter().map(|&(n, t)| (n.ln(), t.ln())).collect();
    let k = logs.len() as f64;
    let (sx, sy) = logs
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x, b + y));
    let (mx, my) = (sx / k, sy / k);
    let (num, den) = logs.iter().fold((0.0, 0.0), |(a, b), &(x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    num / den
}
