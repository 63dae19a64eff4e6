//! Legacy VTK particle files as SPlisHSPlasH writes them (`enableVTKExport`: binary
//! big-endian, `id` as SCALARS, `velocity` in a FIELD, unpadded frame numbers), and the
//! same frame rewritten by meshio (VTK 5.1, ASCII and binary): read alike, skinned end to
//! end, broken files one line.

mod common;

use activeskin::particles::read;
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
}

#[cfg(feature = "vdb")]
#[test]
fn a_splishsplash_vtk_sequence_is_skinned() {
    let out = common::scratch();
    let mesh = out.path().join("s.####.obj");
    let result = common::activeskin(&[
        "particles",
        "--particles",
        &data("sph/vtk/ParticleData_Fluid_#.vtk"),
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
        assert!((0.85..1.2).contains(&volume), "frame {f}: {volume}");
    }
}

#[test]
fn a_cut_vtk_file_is_one_line() {
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
}
