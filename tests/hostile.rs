//! Random hostile inputs (issue 31): particle clouds with stray points far out, NaN or
//! infinite coordinates and absurd velocities; level sets with inside tiles out to the
//! tree's edge, huge or NaN values; absurd options. Each run ends within 60 s under a
//! 4 GB address space with at most 1 GB resident, exits 0, 1 (bad data) or 2 (bad
//! usage), says what is wrong in at most three lines, never panics, and leaves its inputs
//! as they were. `HOSTILE_SEED=N` replays or explores other cases (the suite runs seeds
//! 1 and 4).
#![cfg(feature = "vdb")]

mod common;

use std::path::{Path, PathBuf};
use std::time::Instant;

use activeskin::vdb::Grid;
use activeskin::volume::Tile;
use common::Lcg;

/// One case: its input files and the arguments that read them.
struct Case {
    what: String,
    inputs: Vec<PathBuf>,
    args: Vec<String>,
}

/// Each case's inputs are under 1 MB: its run stays under 1 GB resident (issue 31).
const PEAK_BYTES: u64 = 1_000_000_000;

fn pick<'a, T>(rng: &mut Lcg, from: &'a [T]) -> &'a T {
    &from[(rng.next_u64() % from.len() as u64) as usize]
}

/// A ball of particles 2r apart (r = 0.02) at `at`, with a velocity each.
fn ball(at: [f32; 3]) -> Vec<[f32; 6]> {
    let mut points = Vec::new();
    for x in -5i32..=5 {
        for y in -5i32..=5 {
            for z in -5i32..=5 {
                if x * x + y * y + z * z <= 25 {
                    let p = [x, y, z].map(|c| c as f32 * 0.04);
                    points.push([p[0] + at[0], p[1] + at[1], p[2] + at[2], 0.0, 0.0, -1.0]);
                }
            }
        }
    }
    points
}

fn write_ply(path: &Path, points: &[[f32; 6]]) {
    let mut text = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float vx\nproperty float vy\nproperty float vz\nend_header\n",
        points.len()
    );
    for p in points {
        text += &format!("{} {} {} {} {} {}\n", p[0], p[1], p[2], p[3], p[4], p[5]);
    }
    std::fs::write(path, text).unwrap();
}

fn particles_case(rng: &mut Lcg, dir: &Path) -> Case {
    let mut frames = [ball([0.0; 3]), ball([0.0, 0.0, -0.05])];
    let huge = [1e2f32, 1e4, 1e6, 1e10, 1e30, f32::INFINITY, f32::NAN];
    let damage = rng.next_u64() % 4;
    let what = match damage {
        0 => {
            let v = *pick(rng, &huge);
            let axis = (rng.next_u64() % 3) as usize;
            for f in &mut frames {
                let mut stray = f[0];
                stray[axis] = v;
                f.push(stray);
            }
            format!("a stray particle at {v} on axis {axis}")
        }
        1 => {
            let v = *pick(rng, &huge);
            frames[1][7][3] = v;
            format!("one velocity of {v}")
        }
        2 => {
            let n = frames[0].len();
            let v = *pick(rng, &huge);
            frames[1][n / 2][2] = -v;
            format!("one particle at z = {} in frame 2", -v)
        }
        _ => "no damage".into(),
    };
    let mut inputs = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        let path = dir.join(format!("p.{:04}.ply", k + 1));
        write_ply(&path, f);
        inputs.push(path);
    }
    let radius = *pick(rng, &["0.02", "0.02", "1e-5", "5", "1e4"]);
    let mut args: Vec<String> = [
        "particles",
        "--particles",
        dir.join("p.####.ply").to_str().unwrap(),
        "--radius",
        radius,
        "--mesh",
        dir.join("out/m.####.obj").to_str().unwrap(),
        "-q",
    ]
    .map(String::from)
    .to_vec();
    let option = options(rng, &mut args);
    Case {
        what: format!("particles: {what}, radius {radius}{option}"),
        inputs,
        args,
    }
}

/// Adds an absurd option to `args` one case in two; says which.
fn options(rng: &mut Lcg, args: &mut Vec<String>) -> String {
    let choices: [(&str, &[&str]); 5] = [
        ("--alpha", &["1e9", "-1", "nan", "0"]),
        ("--fps", &["1e-9", "0", "1e9"]),
        ("--voxel-size", &["1e-6", "1e4", "inf"]),
        ("--velocity-scale", &["1e30", "-1", "nan"]),
        ("--beta", &["1e9", "-1"]),
    ];
    if rng.next_u64() % 2 == 0 {
        return String::new();
    }
    let (flag, values) = pick(rng, &choices);
    let value = *pick(rng, values);
    args.extend([flag.to_string(), value.to_string()]);
    format!(", {flag} {value}")
}

fn level_set_case(rng: &mut Lcg, dir: &Path) -> Case {
    let sphere = Grid::level_set_sphere(0.5, [0.0; 3], 0.025, 3.0).unwrap();
    let mut data = sphere.to_data().unwrap();
    let bg = data.background;
    let what = match rng.next_u64() % 5 {
        0 => {
            // Inside tiles of 128³ from the sphere out to 30 tiles away.
            for i in 1..=30 {
                for j in -3..3 {
                    data.tiles.push(Tile {
                        origin: [i * 128, j * 128, 0],
                        dim: 128,
                        value: -bg,
                        active: rng.next_u64() % 2 == 0,
                    });
                }
            }
            "inside tiles to the tree's edge".to_string()
        }
        1 => {
            let v = *pick(rng, &[1e30f32, -1e30]);
            data.leaf_values.iter_mut().for_each(|x| *x *= v);
            format!("band values scaled by {v}")
        }
        2 => {
            let at = (rng.next_u64() % data.leaf_values.len() as u64) as usize;
            data.leaf_values[at] = *pick(rng, &[f32::NAN, f32::INFINITY]);
            "one NaN or infinite voxel".into()
        }
        3 => {
            data.tiles.push(Tile {
                origin: [4096, 0, 0],
                dim: 4096,
                value: -bg,
                active: rng.next_u64() % 2 == 0,
            });
            "a root tile inside".into()
        }
        _ => "no damage".into(),
    };
    let path = dir.join("ls.vdb");
    common::write_grid(&path, &data);
    let command = *pick(rng, &["skin", "mesh", "validate"]);
    let mut args: Vec<String> = match command {
        "skin" => [
            "skin",
            "--target",
            path.to_str().unwrap(),
            "--frames",
            "1-2",
            "--mesh",
            dir.join("out/s.####.obj").to_str().unwrap(),
            "-q",
        ]
        .map(String::from)
        .to_vec(),
        "mesh" => vec![
            "mesh".into(),
            path.to_str().unwrap().into(),
            dir.join("out.obj").to_str().unwrap().into(),
        ],
        _ => vec!["validate".into(), path.to_str().unwrap().into()],
    };
    let option = if command == "skin" {
        options(rng, &mut args)
    } else {
        String::new()
    };
    Case {
        what: format!("{command}: {what}{option}"),
        inputs: vec![path],
        args,
    }
}

#[test]
fn hostile_inputs_end_in_a_clear_line_within_bounds() {
    let seeds: Vec<u64> = match std::env::var("HOSTILE_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        Some(seed) => vec![seed],
        // Seed 4 holds a cloud whose density would take 10 GB (radius 10 µm, voxel 1 µm).
        None => vec![1, 4],
    };
    let mut failures = Vec::new();
    for seed in seeds {
        run_seed(seed, &mut failures);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_memory_budget_is_an_option() {
    let dir = common::scratch();
    let path = dir.path().join("p.0001.ply");
    write_ply(&path, &ball([0.0; 3]));
    let run = |budget: &str| {
        common::activeskin(&[
            "particles",
            "--particles",
            dir.path().join("p.####.ply").to_str().unwrap(),
            "--radius",
            "0.02",
            "--frames",
            "1-1",
            "--mesh",
            dir.path().join("m.####.obj").to_str().unwrap(),
            "--max-memory",
            budget,
            "-q",
        ])
    };
    common::assert_fails(&run("0"), 2, "--max-memory", "zero");
    common::assert_fails(&run("nan"), 2, "--max-memory", "nan");
    let out = run("0.0001");
    common::assert_fails(&out, 1, "p.0001.ply", "100 kB");
    assert!(common::stderr(&out).contains("memory budget of 100.0 kB"));
    common::assert_ok(&run("2"));
}

fn run_seed(seed: u64, failures: &mut Vec<String>) {
    let mut rng = Lcg(seed);
    for k in 0..24 {
        let dir = common::scratch();
        let case = if k % 2 == 0 {
            particles_case(&mut rng, dir.path())
        } else {
            level_set_case(&mut rng, dir.path())
        };
        let before: Vec<Vec<u8>> = case
            .inputs
            .iter()
            .map(|p| std::fs::read(p).unwrap())
            .collect();
        let start = Instant::now();
        let (out, peak) = common::activeskin_measured(&case.args);
        let took = start.elapsed();
        let err = common::stderr(&out);
        let code = out.status.code();
        let lines = err.trim_end().lines().count();
        let whole = case
            .inputs
            .iter()
            .zip(&before)
            .all(|(p, b)| std::fs::read(p).is_ok_and(|now| now == *b));
        let fine = matches!(code, Some(0..=2))
            && (code == Some(0) || (1..=3).contains(&lines))
            && !err.contains("panicked")
            && whole
            && peak <= PEAK_BYTES;
        println!(
            "seed {seed} case {k}: {} -> {code:?} in {:.1} s, {} MB{}",
            case.what,
            took.as_secs_f64(),
            peak / 1_000_000,
            err.lines()
                .next()
                .map(|l| format!(": {l}"))
                .unwrap_or_default()
        );
        if !fine {
            failures.push(format!(
                "seed {seed} case {k} ({}): exit {code:?}, {lines} lines, inputs whole {whole}, peak {} MB: {}",
                case.what,
                peak / 1_000_000,
                err.chars().take(400).collect::<String>()
            ));
        }
    }
}

/// An analytic shape far larger than its voxels — as the start or as the target — is
/// refused in one line before its blocks are listed (a sphere of radius 1 at voxels of
/// 1e-4 used to abort asking for 3.9 GB; one of radius 1000 as the target, 250 TB).
#[test]
fn a_shape_too_large_for_its_voxels_is_refused_within_the_budget() {
    let dir = common::scratch();
    let mesh = dir.path().join("m.####.obj");
    let morph = |from: &str, to: &str, voxel: &str, budget: &str| {
        let start = Instant::now();
        let out = common::activeskin_bounded(&[
            "morph",
            "--from",
            from,
            "--to",
            to,
            "--voxel-size",
            voxel,
            "--frames",
            "1-1",
            "--mesh",
            mesh.to_str().unwrap(),
            "--max-memory",
            budget,
            "-q",
        ]);
        assert!(start.elapsed().as_secs() < 10, "{from} → {to}");
        out
    };
    for (from, to, voxel) in [
        ("sphere:r=1", "sphere:r=1", "1e-4"),
        ("sphere:r=0.1", "sphere:r=1000", "1e-2"),
    ] {
        let out = morph(from, to, voxel, "2");
        common::assert_fails(&out, 1, "memory budget of 2.0 GB", to);
        assert!(common::stderr(&out).contains("voxel size"), "{to}");
    }
    // The band's own estimate: a sphere 125 voxels in radius takes 0.2 GB.
    common::assert_fails(
        &morph("sphere:r=1", "sphere:r=1", "8e-3", "0.1"),
        1,
        "over the memory budget of 100.0 MB",
        "band",
    );
    common::assert_ok(&morph("sphere:r=1", "sphere:r=1", "8e-3", "1"));
    assert_eq!(common::names(dir.path()), vec!["m.0001.obj".to_string()]);
}

/// A VDB grid larger in memory than the budget is refused before OpenVDB reads it, from
/// the size its writer recorded (OpenVDB's `file_mem_bytes`).
#[test]
fn a_vdb_grid_over_the_budget_is_refused_before_it_is_read() {
    let dir = common::scratch();
    let path = dir.path().join("sphere.vdb");
    let sphere = Grid::level_set_sphere(1.0, [0.0; 3], 0.02, 3.0).unwrap();
    let meta = activeskin::vdb::FileMetadata {
        creator: "test".into(),
        has_frame: false,
        frame: 0,
    };
    activeskin::vdb::write_grids(&path, &[(&sphere, Default::default())], &meta).unwrap();
    let recorded = activeskin::vdb::recorded_memory(&path, Some("surface"))
        .unwrap()
        .unwrap();
    // 188 574 active voxels in about 2 200 leaves of 2 KB, with the upper nodes.
    assert!(
        (2_000_000..8_000_000).contains(&recorded),
        "recorded {recorded} bytes"
    );
    let mesh = |budget: &str| {
        common::activeskin(&[
            "mesh",
            path.to_str().unwrap(),
            dir.path().join("m.obj").to_str().unwrap(),
            "--max-memory",
            budget,
        ])
    };
    let out = mesh("0.001");
    common::assert_fails(&out, 1, "sphere.vdb", "over the budget");
    assert!(common::stderr(&out).contains("as its writer recorded"));
    common::assert_ok(&mesh("0.05"));
}
