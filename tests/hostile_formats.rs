//! Hostile files in the particle formats and outputs that would collide (issue 52): each
//! run ends under a 4 GB address space within 60 s, with at most 1 GB resident, in one
//! printable line naming what is wrong (exit 1 for bad data, 2 for bad usage), or with a
//! right result.

mod common;

use std::path::Path;
use std::process::Output;

/// Each case's inputs are under 4 MB: its run stays under 1 GB resident.
const PEAK_BYTES: u64 = 1_000_000_000;

/// `particles` on `input` (one frame), meshes written into `dir`, with `extra`.
fn particles(input: &Path, dir: &Path, extra: &[&str]) -> Output {
    let mesh = dir.join("mesh.####.obj");
    run(
        input,
        &[&["--mesh", mesh.to_str().unwrap()], extra].concat(),
    )
}

/// `particles` on `input` (one frame) with `options` (its outputs among them): its
/// output, its peak memory checked against the bound.
fn run(input: &Path, options: &[&str]) -> Output {
    let mut args: Vec<&str> = vec![
        "particles",
        "--particles",
        input.to_str().unwrap(),
        "--radius",
        "0.01",
        "--frames",
        "1-1",
        "-q",
    ];
    args.extend_from_slice(options);
    let (out, peak) = common::activeskin_measured(&args);
    assert!(
        peak <= PEAK_BYTES,
        "{}: {} MB resident",
        input.display(),
        peak / 1_000_000
    );
    out
}

/// Exit `code` with one printable line holding `says`.
fn refused(out: &Output, code: i32, says: &str) {
    let err = common::stderr(out);
    assert_eq!(out.status.code(), Some(code), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.trim_end().chars().all(|c| !c.is_control()),
        "not printable: {err:?}"
    );
    assert!(err.contains(says), "expected '{says}' in: {err}");
}

/// A binary PLY of `points`.
fn write_ply(path: &Path, points: &[[f32; 3]]) {
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        points.len()
    )
    .into_bytes();
    for p in points {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn an_lzma_bomb_stops_at_its_stated_size() {
    // 52 KB whose one block says 4 800 bytes and inflates to 256 MB
    // (data/hostile/make_hostile.py): lzma-rs would hold all of it before writing any.
    let dir = common::scratch();
    let bomb = common::data("hostile/lzma_bomb.vtu");
    let out = particles(Path::new(&bomb), dir.path(), &[]);
    refused(&out, 1, "inflates past its stated size");
    assert!(common::stderr(&out).contains("lzma_bomb.vtu"));
}

/// A `.pvtu` listing `sources` in `dir`.
fn write_pvtu(dir: &Path, sources: &[&str]) -> std::path::PathBuf {
    let pieces: String = sources
        .iter()
        .map(|s| format!("    <Piece Source=\"{s}\"/>\n"))
        .collect();
    let path = dir.join("frame_1.pvtu");
    std::fs::write(
        &path,
        format!(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\">\n  <PUnstructuredGrid>\n    <PPoints><PDataArray type=\"Float32\" NumberOfComponents=\"3\"/></PPoints>\n{pieces}  </PUnstructuredGrid>\n</VTKFile>\n"
        ),
    )
    .unwrap();
    path
}

#[test]
fn pvtu_pieces_are_read_only_from_regular_files_each_once() {
    let dir = common::scratch();
    let piece = dir.path().join("piece_0.vtu");
    std::fs::copy(common::data("sph/vtu/pieces_0.vtu"), &piece).unwrap();
    // A device that never ends: refused before a byte is read.
    let pvtu = write_pvtu(dir.path(), &["piece_0.vtu", "/dev/zero"]);
    refused(
        &particles(&pvtu, dir.path(), &[]),
        1,
        "is a device, not a file",
    );
    // One piece named twice (or 20 000 times) is the same particles on top of each other.
    let pvtu = write_pvtu(dir.path(), &["piece_0.vtu", "./piece_0.vtu"]);
    refused(&particles(&pvtu, dir.path(), &[]), 1, "more than once");
    // A named pipe would block its reader until something writes to it.
    let fifo = dir.path().join("pipe.vtu");
    if std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        let pvtu = write_pvtu(dir.path(), &["piece_0.vtu", "pipe.vtu"]);
        refused(&particles(&pvtu, dir.path(), &[]), 1, "named pipe");
    }
    // The piece alone is read.
    let pvtu = write_pvtu(dir.path(), &["piece_0.vtu"]);
    common::assert_ok(&particles(&pvtu, dir.path(), &[]));
}

#[test]
fn coincident_particles_cost_what_their_neighbourhoods_hold_not_their_pairs() {
    // 300 000 particles on one point: 9·10¹⁰ pairs, over the 60 s bound when summed pair
    // by pair (100 000 took 24 s), and 1 million more spread 1 000 to a neighbourhood.
    // Each is a droplet.
    let dir = common::scratch();
    let pile = dir.path().join("pile.ply");
    write_ply(&pile, &vec![[0.5, 0.5, 0.5]; 300_000]);
    common::assert_ok(&particles(&pile, dir.path(), &[]));
    let mesh = std::fs::read_to_string(dir.path().join("mesh.0001.obj")).unwrap();
    let faces = mesh.lines().filter(|l| l.starts_with("f ")).count();
    assert!((100..5000).contains(&faces), "{faces} faces: not a droplet");
    let mut state = 7u64;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let spread: Vec<[f32; 3]> = (0..200_000)
        .map(|_| [next() * 0.06, next() * 0.06, next() * 0.06])
        .collect();
    let dense = dir.path().join("dense.ply");
    write_ply(&dense, &spread);
    common::assert_ok(&particles(&dense, dir.path(), &[]));
}

#[test]
fn outputs_that_would_overwrite_each_other_are_refused_before_frame_one() {
    let dir = common::scratch();
    let input = dir.path().join("drop.ply");
    write_ply(&input, &[[0.5, 0.5, 0.5], [0.52, 0.5, 0.5]]);
    let mesh = dir.path().join("o.####.ply");
    let mesh = mesh.to_str().unwrap();
    let run = |options: &[&str]| run(&input, options);
    // The density's fog volumes onto the skin's level sets.
    let vdb = dir.path().join("o.####.vdb");
    let vdb = vdb.to_str().unwrap();
    let out = run(&["--out", vdb, "--density-out", vdb]);
    refused(&out, 2, "would both write");
    // A VDB under another format's name.
    let density = dir.path().join("density.####.ply");
    let out = run(&["--density-out", density.to_str().unwrap(), "--mesh", mesh]);
    refused(&out, 2, "VDB fog volumes must end in .vdb");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "nothing written"
    );
}

#[test]
fn messages_are_one_printable_line_whatever_the_file_or_the_argument_holds() {
    let dir = common::scratch();
    let vtk = std::fs::read(common::data("sph/vtk/ParticleData_Fluid_2.vtk")).unwrap();
    let edit = |from: &[u8], to: &[u8]| -> Vec<u8> {
        let at = vtk.windows(from.len()).position(|w| w == from).unwrap();
        [&vtk[..at], to, &vtk[at + from.len()..]].concat()
    };
    // A SCALARS of no component: its binary data read as the next keyword echoed 1 675
    // characters with NULs.
    let none = dir.path().join("none.vtk");
    std::fs::write(
        &none,
        edit(b"SCALARS id unsigned_int 1", b"SCALARS id unsigned_int 0"),
    )
    .unwrap();
    refused(
        &particles(&none, dir.path(), &[]),
        1,
        "SCALARS id: bad component count",
    );
    // Binary bytes where a keyword belongs.
    let junk = dir.path().join("junk.vtk");
    std::fs::write(&junk, edit(b"POINT_DATA 324", b"\x01\x02\x00\xff\xfe 324")).unwrap();
    refused(
        &particles(&junk, dir.path(), &[]),
        1,
        "binary data where a keyword",
    );
    // An attribute named with a newline, echoed escaped.
    let input = common::data("sph/vtk/ParticleData_Fluid_2.vtk");
    let mesh = dir.path().join("m.####.ply");
    let out = run(
        Path::new(&input),
        &[
            "--mesh",
            mesh.to_str().unwrap(),
            "--attribute",
            "age\nrm -rf",
        ],
    );
    refused(&out, 1, "no particle attribute 'age\\nrm -rf'");
}

#[test]
fn a_velocity_without_a_row_per_point_is_an_error_not_dropped() {
    let dir = common::scratch();
    let vtk = dir.path().join("short.vtk");
    std::fs::write(
        &vtk,
        "# vtk DataFile Version 3.0\nshort\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 0.02 0 0 0.04 0 0\nPOINT_DATA 3\nFIELD FieldData 1\nvelocity 3 2 float\n1 0 0 1 0 0\n",
    )
    .unwrap();
    refused(
        &particles(&vtk, dir.path(), &[]),
        1,
        "array 'velocity' has 2 rows for 3 points",
    );
    // Another point array too: said, not dropped (an --attribute asking for it was told
    // the file has no such attribute).
    std::fs::write(
        &vtk,
        "# vtk DataFile Version 3.0\nshort\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 0.02 0 0 0.04 0 0\nPOINT_DATA 3\nFIELD FieldData 1\nage 1 2 float\n1 2\n",
    )
    .unwrap();
    refused(
        &particles(&vtk, dir.path(), &[]),
        1,
        "array 'age' has 2 rows for 3 points",
    );
}
