//! Particle files as SPlisHSPlasH writes them, from one run of pysplishsplash 2.19
//! (`data/sph/`): legacy VTK (`enableVTKExport`: binary big-endian, `id` as SCALARS,
//! `velocity` in a FIELD) and partio BGEO (`enablePartioExport`: gzipped classic BGEO,
//! whose x holds the id's bits — refused with one line saying so), unpadded frame
//! numbers; the VTK frame rewritten by meshio (VTK 5.1, ASCII and binary) and as VTK XML
//! by VTK 9.7's own writers (ParaView's) in every data mode and compressor, and by meshio
//! (`data/sph/vtu/make_fixtures.py`). Read alike, skinned end to end, broken files one
//! line.

mod common;

use activeskin::io::particles::read;
use common::data;
use std::path::Path;

fn frame(name: &str) -> activeskin::particles::Particles {
    read(Path::new(&data(&format!("sph/vtk/{name}")))).unwrap()
}

#[test]
fn splishsplash_and_meshio_files_read_alike() {
    let ours = frame("ParticleData_Fluid_2.vtk");
    assert_eq!(ours.positions.len(), 324);
    let ids = ours.ids.as_ref().expect("SPlisHSPlasH's id SCALARS");
    let mut sorted = ids.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), 324, "ids are unique");
    let v = ours
        .velocities
        .as_ref()
        .expect("SPlisHSPlasH's velocity FIELD");
    // A block of water just released: falling, about g·t.
    let mean_vy = v.iter().map(|v| v.y).sum::<f32>() / v.len() as f32;
    assert!((-0.6..-0.2).contains(&mean_vy), "{mean_vy}");
    for rewrite in ["meshio_ascii_2.vtk", "meshio_binary_2.vtk"] {
        let other = frame(rewrite);
        assert_eq!(other.positions, ours.positions, "{rewrite}");
        assert_eq!(other.velocities, ours.velocities, "{rewrite}");
    }
    // The same frame exported through partio: its x holds the ids, which it names.
    let partio = data("sph/bgeo/ParticleData_Fluid_2.bgeo");
    let e = read(Path::new(&partio)).unwrap_err().to_string();
    assert!(
        e.contains("x holds the particle's id") && e.contains("VTK"),
        "{e}"
    );
    let raw = std::fs::read(&partio).unwrap();
    let points = activeskin::io::bgeo::parse(&raw, 1 << 24).unwrap();
    for (i, (p, q)) in points.positions.iter().zip(&ours.positions).enumerate() {
        assert_eq!([p[1], p[2]], [q.y, q.z]);
        assert_eq!(i64::from(p[0].to_bits()), ids[i]);
    }
    let v = &activeskin::io::find_array(&points.attributes, &["velocity"], 3)
        .unwrap()
        .values;
    assert_eq!(v[1] as f32, ours.velocities.as_ref().unwrap()[0].y);
}

/// VTK XML as ParaView's writers save it — ASCII, inline base64, appended raw or base64;
/// no compression, zlib in 1 KiB blocks, LZ4, LZMA; 32- and 64-bit headers; both byte
/// orders — a PolyData, meshio's writer, and a parallel file of two pieces: the same
/// particles, velocities and ids as the legacy file they were made from.
#[test]
fn vtk_xml_files_read_as_the_legacy_file() {
    let legacy = frame("ParticleData_Fluid_2.vtk");
    for name in [
        "ascii.vtu",
        "binary.vtu",
        "binary_zlib.vtu",
        "appended_raw.vtu",
        "appended_raw_zlib.vtu",
        "appended_base64_lz4.vtu",
        "appended_lzma.vtu",
        "polydata.vtp",
        "meshio.vtu",
        "pieces.pvtu",
    ] {
        let xml = read(Path::new(&data(&format!("sph/vtu/{name}"))))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        // ASCII holds the floats as printed: within their last digit.
        if name == "ascii.vtu" {
            let close = |a: f32, b: f32| (a - b).abs() <= 1e-6 * b.abs().max(1.0);
            assert_eq!(xml.positions.len(), legacy.positions.len());
            for (p, q) in xml.positions.iter().zip(&legacy.positions) {
                assert!((0..3).all(|k| close(p[k], q[k])), "{name}: {p} {q}");
            }
        } else {
            assert_eq!(xml.positions, legacy.positions, "{name}");
        }
        assert_eq!(xml.ids, legacy.ids, "{name}");
        let (a, b) = (xml.velocities.unwrap(), legacy.velocities.clone().unwrap());
        assert_eq!(a.len(), b.len(), "{name}");
        for (u, v) in a.iter().zip(&b) {
            assert!((*u - *v).abs().max_element() <= 1e-6, "{name}: {u} {v}");
        }
    }
}

/// VTK XML files cut, or naming what they do not hold: one line, naming the file and
/// what is wrong.
#[test]
fn broken_vtk_xml_files_are_one_line() {
    let dir = common::scratch();
    let cases: Vec<(&str, Vec<u8>, &str)> = {
        let zlib = std::fs::read(data("sph/vtu/appended_raw_zlib.vtu")).unwrap();
        let inline = std::fs::read(data("sph/vtu/binary.vtu")).unwrap();
        let text = String::from_utf8(inline.clone()).unwrap();
        vec![
            // Cut 100 bytes into its appended data: inside its first array.
            (
                "cut.vtu",
                {
                    let tag = zlib
                        .windows(13)
                        .position(|w| w == b"<AppendedData")
                        .unwrap();
                    let data = tag + zlib[tag..].iter().position(|&b| b == b'_').unwrap();
                    zlib[..data + 100].to_vec()
                },
                "ends",
            ),
            (
                "cut_inline.vtu",
                inline[..inline.len() / 2].to_vec(),
                "ends inside <DataArray>",
            ),
            (
                "image.vti",
                text.replace("UnstructuredGrid", "ImageData").into_bytes(),
                "",
            ),
            (
                "image.vtu",
                text.replace("\"UnstructuredGrid\"", "\"ImageData\"")
                    .into_bytes(),
                "ImageData",
            ),
            (
                "lzo.vtu",
                text.replace(
                    "header_type",
                    "compressor=\"vtkLZODataCompressor\" header_type",
                )
                .into_bytes(),
                "vtkLZODataCompressor",
            ),
            (
                "none.pvtu",
                b"<VTKFile type=\"PUnstructuredGrid\"></VTKFile>".to_vec(),
                "Piece",
            ),
            (
                "missing.pvtu",
                b"<VTKFile type=\"PUnstructuredGrid\"><Piece Source=\"gone.vtu\"/></VTKFile>"
                    .to_vec(),
                "gone.vtu",
            ),
        ]
    };
    for (name, bytes, says) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let e = match read(&path) {
            Ok(p) => panic!("{name}: read {} particles", p.positions.len()),
            Err(e) => e.to_string(),
        };
        assert!(
            e.starts_with(path.to_str().unwrap()) && !e.contains('\n'),
            "{name}: {e}"
        );
        assert!(e.contains(says), "{name}: {e}");
    }
}

#[cfg(feature = "vdb")]
#[test]
fn a_splishsplash_vtk_sequence_is_skinned() {
    skinned("vtk/ParticleData_Fluid_#.vtk");
}

#[cfg(feature = "vdb")]
fn skinned(pattern: &str) {
    let out = common::scratch();
    let mesh = out.path().join("s.####.obj");
    let result = common::activeskin(&[
        "particles",
        "--particles",
        &data(&format!("sph/{pattern}")),
        "--radius",
        "0.01",
        "--mesh",
        mesh.to_str().unwrap(),
    ]);
    common::assert_ok(&result);
    // Three closed meshes (the scratch folder checks them), each enclosing about the
    // particles' own volume N·(2r)³.
    for f in 1..=3 {
        let m = common::read_mesh(&out.path().join(format!("s.{f:04}.obj"))).unwrap();
        let volume = m.area_and_volume().1 / (324.0 * 0.02f64.powi(3));
        assert!(
            (0.85..1.2).contains(&volume),
            "{pattern} frame {f}: {volume}"
        );
    }
}

#[test]
fn cut_files_are_one_line() {
    let dir = common::scratch();
    let bytes = std::fs::read(data("sph/vtk/ParticleData_Fluid_1.vtk")).unwrap();
    for keep in [40, 2000, bytes.len() - 30] {
        let path = dir.path().join("cut.vtk");
        std::fs::write(&path, &bytes[..keep]).unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(
            e.starts_with(path.to_str().unwrap()) && !e.contains('\n'),
            "{e}"
        );
        assert!(e.contains("ends inside"), "{keep}: {e}");
    }
    // A gzipped BGEO cut short, and inflated then cut.
    let gz = std::fs::read(data("sph/bgeo/ParticleData_Fluid_1.bgeo")).unwrap();
    let mut raw = Vec::new();
    std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(&gz[..]), &mut raw).unwrap();
    for (bytes, what) in [
        (&gz[..gz.len() / 2], "gzip"),
        (&raw[..raw.len() / 2], "ends inside"),
    ] {
        let path = dir.path().join("cut.bgeo");
        std::fs::write(&path, bytes).unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(
            e.starts_with(path.to_str().unwrap()) && !e.contains('\n'),
            "{e}"
        );
        assert!(e.contains(what), "{what}: {e}");
    }
}

#[test]
fn splashsurfs_json_and_its_frame_pattern() {
    let dir = common::scratch();
    let vtk = frame("ParticleData_Fluid_2.vtk");
    let json: Vec<[f32; 3]> = vtk.positions.iter().map(|p| p.to_array()).collect();
    let path = dir.path().join("fluid_7.json");
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    assert_eq!(read(&path).unwrap().positions, vtk.positions);
    // splashsurf's `{}` names the unpadded frame.
    let pattern = activeskin::sequence::FramePattern::parse(
        dir.path().join("fluid_{}.json").to_str().unwrap(),
    )
    .unwrap();
    assert_eq!(pattern.existing_frames().unwrap(), vec![7]);
    std::fs::write(&path, "[[0, 1], [2, 3, 4]]").unwrap();
    let e = read(&path).unwrap_err().to_string();
    assert!(e.contains("[x, y, z]") && !e.contains('\n'), "{e}");
}

/// The real files damaged at random — bytes flipped, cut, repeated, counts and sizes
/// scrambled — and the gzip inside the BGEO too: every reader returns an error or finite
/// particles, never panics, never reserves more than the file could hold.
#[test]
fn damaged_files_never_panic() {
    use activeskin::io::particles::{parse, Format};
    let gz = std::fs::read(data("sph/bgeo/ParticleData_Fluid_2.bgeo")).unwrap();
    let mut raw = Vec::new();
    std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(&gz[..]), &mut raw).unwrap();
    let seeds: Vec<(Vec<u8>, Format)> = vec![
        (
            std::fs::read(data("sph/vtk/ParticleData_Fluid_2.vtk")).unwrap(),
            Format::VTK,
        ),
        (
            std::fs::read(data("sph/vtk/meshio_ascii_2.vtk")).unwrap(),
            Format::VTK,
        ),
        (
            std::fs::read(data("sph/vtk/meshio_binary_2.vtk")).unwrap(),
            Format::VTK,
        ),
        (gz, Format::BGEO),
        (raw, Format::BGEO),
        (b"[[0, 1, 2], [3.5, 4, 5e-3]]".to_vec(), Format::JSON),
    ];
    let seeds: Vec<(Vec<u8>, Format)> = seeds
        .into_iter()
        .chain(
            [
                "ascii.vtu",
                "binary_zlib.vtu",
                "appended_raw.vtu",
                "appended_base64_lz4.vtu",
                "appended_lzma.vtu",
            ]
            .iter()
            .map(|name| {
                let bytes = std::fs::read(data(&format!("sph/vtu/{name}"))).unwrap();
                (bytes, Format::VTU)
            }),
        )
        .collect();
    let mut rng = common::Lcg(2026);
    for (seed, format) in &seeds {
        for _ in 0..300 {
            let mut bytes = seed.clone();
            for _ in 0..1 + rng.next_u64() % 4 {
                let at = (rng.next_u64() as usize) % bytes.len().max(1);
                match rng.next_u64() % 4 {
                    0 => bytes[at] = (rng.next_u64() >> 56) as u8,
                    1 => bytes.truncate(at),
                    // A header digit or count made huge.
                    2 => {
                        bytes.splice(at..at, *b"99999999999");
                    }
                    _ => {
                        let chunk: Vec<u8> = bytes[at..].iter().take(64).copied().collect();
                        bytes.splice(at..at, chunk);
                    }
                }
                if bytes.is_empty() {
                    break;
                }
            }
            if let Ok(p) = parse(&bytes, *format) {
                assert!(p.positions.iter().all(|p| p.is_finite()));
                for n in [
                    p.radii.as_ref().map(Vec::len),
                    p.velocities.as_ref().map(Vec::len),
                    p.ids.as_ref().map(Vec::len),
                ]
                .into_iter()
                .flatten()
                {
                    assert_eq!(n, p.positions.len());
                }
            }
        }
    }
}

/// The same particles in every format give the same skin, byte for byte: SPlisHSPlasH's
/// VTK frames; the PLY they convert to ([`activeskin::io::ply::write_particles`]); its
/// own partio BGEO of the same frames (gzipped behind a plain `.bgeo`, as it writes them)
/// with each x put back where pysplishsplash wrote the id's bits; and for frame 2,
/// ParaView's VTK XML (appended raw, zlib) and meshio's.
#[cfg(feature = "vdb")]
#[test]
fn every_format_gives_the_same_meshes() {
    use std::io::{Read, Write};
    let dir = common::scratch();
    for folder in ["vtk", "ply", "bgeo", "vtu", "ply2", "meshio"] {
        std::fs::create_dir_all(dir.path().join(folder)).unwrap();
    }
    for f in 1..=3 {
        let name = format!("ParticleData_Fluid_{f}");
        let vtk_path = data(&format!("sph/vtk/{name}.vtk"));
        std::fs::copy(&vtk_path, dir.path().join(format!("vtk/{name}.vtk"))).unwrap();
        let vtk = read(Path::new(&vtk_path)).unwrap();
        let ply = dir.path().join(format!("ply/{name}.ply"));
        activeskin::io::ply::write_particles(&ply, &vtk).unwrap();
        assert_eq!(read(&ply).unwrap(), vtk, "the PLY reads back as written");
        if f == 2 {
            let ply2 = dir.path().join(format!("ply2/{name}.ply"));
            std::fs::copy(&ply, ply2).unwrap();
            for (from, to) in [("appended_raw_zlib.vtu", "vtu"), ("meshio.vtu", "meshio")] {
                let target = dir.path().join(format!("{to}/{name}.vtu"));
                std::fs::copy(data(&format!("sph/vtu/{from}")), target).unwrap();
            }
        }
        // The BGEO, x put back: each point's record holds x (the id's bits), y, z, big
        // endian, in the VTK's order.
        let gz = std::fs::read(data(&format!("sph/bgeo/{name}.bgeo"))).unwrap();
        let mut raw = Vec::new();
        flate2::read::GzDecoder::new(&gz[..])
            .read_to_end(&mut raw)
            .unwrap();
        let ids = vtk.ids.as_ref().unwrap();
        let mut at = 0;
        for (p, &id) in vtk.positions.iter().zip(ids) {
            let mut record = (id as u32).to_be_bytes().to_vec();
            record.extend(p.y.to_be_bytes());
            record.extend(p.z.to_be_bytes());
            let k = at + raw[at..].windows(12).position(|w| w == record).unwrap();
            raw[k..k + 4].copy_from_slice(&p.x.to_be_bytes());
            at = k + 12;
        }
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(&raw).unwrap();
        let bgeo = dir.path().join(format!("bgeo/{name}.bgeo"));
        std::fs::write(&bgeo, gz.finish().unwrap()).unwrap();
        let back = read(&bgeo).unwrap();
        assert_eq!(back.positions, vtk.positions);
        assert_eq!(back.velocities, vtk.velocities);
        assert_eq!(back.ids, vtk.ids);
    }
    let meshes = |folder: &str, ext: &str, frames: std::ops::RangeInclusive<i64>| {
        let out = dir.path().join(format!("{folder}_mesh"));
        let pattern = dir
            .path()
            .join(format!("{folder}/ParticleData_Fluid_#.{ext}"));
        let mesh = out.join("s.####.ply");
        let result = common::activeskin(&[
            "particles",
            "--particles",
            pattern.to_str().unwrap(),
            "--radius",
            "0.01",
            "--mesh",
            mesh.to_str().unwrap(),
            "-q",
        ]);
        common::assert_ok(&result);
        frames
            .map(|f| std::fs::read(out.join(format!("s.{f:04}.ply"))).unwrap())
            .collect::<Vec<_>>()
    };
    let vtk = meshes("vtk", "vtk", 1..=3);
    assert!(vtk.iter().all(|m| m.len() > 1000));
    assert!(meshes("ply", "ply", 1..=3) == vtk, "PLY");
    assert!(meshes("bgeo", "bgeo", 1..=3) == vtk, "BGEO");
    let one = meshes("ply2", "ply", 2..=2);
    assert!(meshes("vtu", "vtu", 2..=2) == one, "VTU (VTK's writer)");
    assert!(meshes("meshio", "vtu", 2..=2) == one, "VTU (meshio)");
}
