//! Helpers shared by the integration tests (each test file uses some of them).
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

use activeskin::mesh::Mesh;
use glam::Vec3;

/// `field` of every line of a `--stats` file, as integers.
pub fn stats_field(path: &Path, field: &str) -> Vec<u64> {
    stats_lines(path)
        .iter()
        .map(|l| {
            l[field]
                .as_u64()
                .unwrap_or_else(|| panic!("{field} in {l}"))
        })
        .collect()
}

/// The JSON object of every line of a `--stats` file.
pub fn stats_lines(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON object per line"))
        .collect()
}

/// Runs the `activeskin` binary built for these tests.
pub fn activeskin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_activeskin"))
        .args(args)
        .output()
        .expect("run activeskin")
}

/// [`activeskin`] within 60 s and a 4 GB address space, as the hostile inputs of issue 31
/// were tried.
pub fn activeskin_bounded<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    activeskin_measured(args).0
}

/// [`activeskin_bounded`], with the run's peak resident memory in bytes.
// The child is reaped by wait4 (for its resource usage), not by `Child::wait`.
#[allow(clippy::zombie_processes)]
pub fn activeskin_measured<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> (Output, u64) {
    use std::io::Read;
    use std::os::unix::process::ExitStatusExt;
    use std::process::Stdio;
    let mut child = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 4000000 && exec timeout 60 \"$@\"")
        .arg("sh")
        .arg(env!("CARGO_BIN_EXE_activeskin"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run activeskin");
    let drain = |mut from: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            let _ = from.read_to_end(&mut bytes);
            bytes
        })
    };
    let stdout = drain(Box::new(child.stdout.take().unwrap()));
    let stderr = drain(Box::new(child.stderr.take().unwrap()));
    let mut status = 0;
    // SAFETY: an all-zero rusage is valid; wait4 reaps our own child, not waited for
    // before (and `child` is not waited for after). Its usage includes the descendants
    // it waited for: `timeout` waits for activeskin.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let reaped = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(reaped, child.id() as i32, "wait4");
    let out = Output {
        status: std::process::ExitStatus::from_raw(status),
        stdout: stdout.join().unwrap(),
        stderr: stderr.join().unwrap(),
    };
    // ru_maxrss is in kilobytes.
    (out, usage.ru_maxrss as u64 * 1024)
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `skin` on `target` at α = 24 writing VDBs to `out`, quietly, plus `extra`.
pub fn skin_args<'a>(target: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "skin", "--target", target, "--alpha", "24", "--out", out, "-q",
    ];
    args.extend_from_slice(extra);
    args
}

/// Writes one grid to a VDB file.
#[cfg(feature = "vdb")]
pub fn write_grid(path: &Path, data: &activeskin::volume::GridData) {
    let grid = activeskin::vdb::Grid::from_data(data).unwrap();
    let meta = activeskin::vdb::FileMetadata {
        creator: "test".into(),
        has_frame: false,
        frame: 0,
    };
    activeskin::vdb::write_grids(path, &[(&grid, Default::default())], &meta).unwrap();
}

/// A file under the repository's `data/`.
pub fn data(path: &str) -> String {
    format!("{}/data/{path}", env!("CARGO_MANIFEST_DIR"))
}

pub fn assert_ok(out: &Output) {
    assert!(out.status.success(), "{}", stderr(out));
}

/// Exit 1 (bad data), one line naming `file`, no panic.
pub fn assert_one_line_error(out: &Output, file: &str) {
    assert_fails(out, 1, file, "bad data");
}

/// Exit 2 (bad usage), one line naming `what`, no panic.
pub fn assert_usage_error(out: &Output, what: &str) {
    assert_fails(out, 2, what, "bad usage");
}

/// Exit `code` (1 bad data, 2 bad usage), one line naming `names`, no panic text.
pub fn assert_fails(out: &Output, code: i32, names: &str, what: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(code), "{what}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{what}: {err}");
    assert!(err.contains(names), "{what}: does not name {names}: {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
}

/// The names in `dir`, sorted (none when it does not exist).
pub fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// Every file under `dir`, in its subfolders too, sorted.
pub fn files_under(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// A repeatable pseudo-random sequence (64-bit LCG, Knuth's constants).
pub struct Lcg(pub u64);

impl Lcg {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0
    }

    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    pub fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| (self.next_u64() >> 56) as u8).collect()
    }
}

/// A scratch folder that, when the test is done with it, checks every mesh written into
/// it (OBJ and PLY with faces, in any sub-folder) with [`Mesh::check`]: every mesh the
/// test suite writes is a clean surface, not just the ones a test looks at.
pub struct Scratch(tempfile::TempDir);

pub fn scratch() -> Scratch {
    Scratch(tempfile::tempdir().expect("a scratch folder"))
}

impl Scratch {
    pub fn path(&self) -> &Path {
        self.0.path()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            assert_clean_meshes(self.path());
        }
    }
}

/// A file of this name in a folder says its meshes are cut to a region (`--region`):
/// [`assert_clean_meshes`] checks them as clean surfaces with a boundary.
pub const CUT_TO_REGION: &str = ".cut-to-region";

/// Checks every mesh under `dir`; returns how many there were.
pub fn assert_clean_meshes(dir: &Path) -> usize {
    let mut checked = 0;
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let open = dir.join(CUT_TO_REGION).is_file();
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            checked += assert_clean_meshes(&path);
            continue;
        }
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        let hidden = path.file_name().unwrap().to_string_lossy().starts_with('.');
        if hidden || !(ext.eq_ignore_ascii_case("obj") || ext.eq_ignore_ascii_case("ply")) {
            continue;
        }
        if let Some(mesh) = read_mesh(&path) {
            let check = mesh.check();
            let clean = match open {
                true => check.is_clean_with_boundary(),
                false => check.is_clean(),
            };
            assert!(clean, "{}: {check}", path.display());
            checked += 1;
        }
    }
    checked
}

/// An OBJ, or a binary little-endian PLY as activeskin writes it (x y z nx ny nz [vx vy
/// vz] floats, uchar-counted int faces); `None` for a file with no faces (a particle
/// file).
pub fn read_mesh(path: &Path) -> Option<Mesh> {
    let bytes = std::fs::read(path).unwrap();
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"))
    {
        return Some(activeskin::io::obj::read(path).unwrap());
    }
    let mut mesh = Mesh::default();
    let end = bytes.windows(11).position(|w| w == b"end_header\n")? + 11;
    let header = String::from_utf8_lossy(&bytes[..end]);
    let count = |key: &str| -> Option<usize> {
        let line = header.lines().find(|l| l.starts_with(key))?;
        line.rsplit(' ').next()?.parse().ok()
    };
    let faces = count("element face")?;
    if !header.contains("binary_little_endian") || !header.contains("property float nz") {
        return None; // not one of ours
    }
    let vertices = count("element vertex")?;
    // x y z nx ny nz, then vx vy vz when the velocities are written.
    let stride = 4 * header
        .lines()
        .skip_while(|l| !l.starts_with("element vertex"))
        .take_while(|l| !l.starts_with("element face"))
        .filter(|l| l.starts_with("property float"))
        .count();
    let word = |o: usize| -> [u8; 4] { bytes[o..o + 4].try_into().unwrap() };
    for v in 0..vertices {
        let f = |k: usize| f32::from_le_bytes(word(end + v * stride + 4 * k));
        mesh.positions.push(Vec3::new(f(0), f(1), f(2)));
        mesh.normals.push(Vec3::new(f(3), f(4), f(5)));
    }
    let start = end + vertices * stride;
    for t in 0..faces {
        let o = start + t * 13;
        assert_eq!(
            bytes[o],
            3,
            "{}: a face that is not a triangle",
            path.display()
        );
        let u = |k: usize| u32::from_le_bytes(word(o + 1 + 4 * k));
        mesh.triangles.push([u(0), u(1), u(2)]);
    }
    Some(mesh)
}

/// An EXR render's first layer: its size and each channel's samples by name.
pub fn exr_channels(path: &Path) -> ((usize, usize), std::collections::HashMap<String, Vec<f32>>) {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    ((layer.size.0, layer.size.1), channels)
}

/// A Python venv of the tests' own, `name` in the build's scratch folder, made with
/// `packages` from pip the first time (when `probe`, a Python statement, fails in it):
/// its Python. Nothing is installed by hand.
pub fn venv(name: &str, packages: &[&str], probe: &str) -> std::path::PathBuf {
    venv_of("python3", name, packages, probe)
}

/// [`venv`] made by the interpreter `python` (a packages' CPython: `bpy` wants one
/// version).
pub fn venv_of(python: &str, name: &str, packages: &[&str], probe: &str) -> std::path::PathBuf {
    let interpreter = python;
    let venv = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let python = venv.join("bin/python");
    let ready = |python: &Path| {
        Command::new(python)
            .args(["-c", probe])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !ready(&python) {
        let made = Command::new(interpreter)
            .args(["-m", "venv", "--clear"])
            .arg(&venv)
            .output()
            .unwrap_or_else(|e| panic!("{interpreter} (make deps installs python3-venv): {e}"));
        assert_ok(&made);
        let installed = Command::new(&python)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
            ])
            .args(packages)
            .output()
            .expect("pip");
        assert_ok(&installed);
        assert!(
            ready(&python),
            "{packages:?} installed, but `{probe}` fails"
        );
    }
    python
}

/// Particles `spacing` apart on a lattice filling a ball `cells` spacings in radius,
/// centred at `at`.
pub fn lattice_ball(at: Vec3, spacing: f32, cells: i32) -> Vec<Vec3> {
    let mut points = Vec::new();
    for x in -cells..=cells {
        for y in -cells..=cells {
            for z in -cells..=cells {
                if x * x + y * y + z * z <= cells * cells {
                    points.push(at + Vec3::new(x as f32, y as f32, z as f32) * spacing);
                }
            }
        }
    }
    points
}

/// Each piece of `mesh`: its enclosed volume and the centroid of its vertices, smallest
/// first.
pub fn mesh_pieces(mesh: &Mesh) -> Vec<(f64, Vec3)> {
    let labels = activeskin::mesh::piece_labels(mesh);
    let n = labels.iter().max().map_or(0, |&l| l as usize + 1);
    let mut found = vec![(0.0f64, Vec3::ZERO, 0usize); n];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize].as_dvec3());
        found[labels[t[0] as usize] as usize].0 += a.dot(b.cross(c)) / 6.0;
    }
    for (p, &label) in mesh.positions.iter().zip(&labels) {
        let piece = &mut found[label as usize];
        (piece.1, piece.2) = (piece.1 + *p, piece.2 + 1);
    }
    let mut out: Vec<(f64, Vec3)> = found
        .into_iter()
        .filter(|piece| piece.2 > 0)
        .map(|(v, sum, n)| (v, sum / n as f32))
        .collect();
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// Frames 1..=`frames` of `frame` written as PLY into `dir`, run through `particles` at
/// voxel = `radius` with `extra` options, meshed: the meshes read back.
pub fn particle_shot(
    dir: &Path,
    frames: i64,
    frame: impl Fn(i64) -> activeskin::particles::Particles,
    radius: f32,
    extra: &[&str],
) -> Vec<Mesh> {
    for f in 1..=frames {
        let path = dir.join(format!("p_{f}.ply"));
        activeskin::io::ply::write_particles(&path, &frame(f)).unwrap();
    }
    let (input, meshes) = (dir.join("p_$F.ply"), dir.join("m.####.obj"));
    let radius = radius.to_string();
    let mut args = vec![
        "particles",
        "--particles",
        input.to_str().unwrap(),
        "--radius",
        &radius,
        "--voxel-size",
        &radius,
        "--mesh",
        meshes.to_str().unwrap(),
        "-q",
    ];
    args.extend(extra);
    assert_ok(&activeskin(&args));
    (1..=frames)
        .map(|f| activeskin::io::obj::read(&dir.join(format!("m.{f:04}.obj"))).unwrap())
        .collect()
}
