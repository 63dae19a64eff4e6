//! `--region` (issue 51): the meshes cut to a box, open on its sides — nothing outside,
//! manifold with the cut as its boundary, the rest of the surface the uncut run's vertex
//! for vertex — while the skin (its VDBs, the stats' area and volume) is the run without
//! it, bit for bit. A region that holds nothing is one line.
#![cfg(feature = "cli")]

mod common;

use std::path::Path;

use activeskin::grid::Aabb;
use common::{activeskin, assert_ok, assert_usage_error, data, read_mesh, scratch, stats_lines};
use glam::Vec3;

/// Through the demo splash's falling drop: its x = 1.5 and z = 1.62 sides cut it.
const REGION: &str = "1.0,0,1.0,1.5,3,1.62";

fn region() -> Aabb {
    Aabb {
        min: Vec3::new(1.0, 0.0, 1.0),
        max: Vec3::new(1.5, 3.0, 1.62),
    }
}

fn run(dir: &Path, extra: &[&str]) {
    let splash = data("splash/drop.####.ply");
    let mesh = dir.join("m.####.ply");
    let stats = dir.join("stats.jsonl");
    let mut args = vec![
        "particles",
        "--particles",
        &splash,
        "--radius",
        "0.04",
        "--frames",
        "1-12",
        "--mesh",
        mesh.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
        "-q",
    ];
    let out = dir.join("s.####.vdb");
    if cfg!(feature = "vdb") {
        args.extend(["--out", out.to_str().unwrap()]);
    }
    args.extend(extra);
    assert_ok(&activeskin(&args));
}

#[test]
fn a_region_cuts_the_meshes_open_and_leaves_the_skin_as_it_is() {
    let dir = scratch();
    let (whole, cut) = (dir.path().join("whole"), dir.path().join("cut"));
    run(&whole, &[]);
    std::fs::create_dir_all(&cut).unwrap();
    std::fs::write(cut.join(common::CUT_TO_REGION), "").unwrap();
    let usd = cut.join("shot.usda");
    run(&cut, &["--region", REGION, "--usd", usd.to_str().unwrap()]);
    let region = region();
    let on_a_side = |p: Vec3| (0..3).any(|a| p[a] == region.min[a] || p[a] == region.max[a]);
    for frame in 1..=12 {
        let name = format!("m.{frame:04}.ply");
        let (a, b) = (
            read_mesh(&whole.join(&name)).unwrap(),
            read_mesh(&cut.join(&name)).unwrap(),
        );
        let check = b.check();
        assert!(check.manifold_with_boundary(), "frame {frame}: {check}");
        assert_eq!(
            (check.coincident, check.degenerate),
            (0, 0),
            "frame {frame}: {check}"
        );
        // Open on the box's sides, and only there.
        assert!(
            check.boundary_edges > 0,
            "frame {frame}: the box cuts the drop"
        );
        for v in b.boundary_vertices() {
            let p = b.positions[v as usize];
            assert!(
                on_a_side(p),
                "frame {frame}: a boundary vertex {p} off the sides"
            );
        }
        for p in &b.positions {
            assert!(
                region.min.cmple(*p).all() && p.cmple(region.max).all(),
                "frame {frame}: {p} outside the region"
            );
        }
        // Inside, away from the sides, the uncut mesh's own vertices.
        let margin = 0.01;
        let inner = |p: &&Vec3| {
            (region.min + Vec3::splat(margin)).cmplt(**p).all()
                && p.cmplt(region.max - Vec3::splat(margin)).all()
        };
        let mut theirs: Vec<[u32; 3]> = a
            .positions
            .iter()
            .filter(inner)
            .map(|p| p.to_array().map(f32::to_bits))
            .collect();
        let mut ours: Vec<[u32; 3]> = b
            .positions
            .iter()
            .filter(inner)
            .map(|p| p.to_array().map(f32::to_bits))
            .collect();
        theirs.sort_unstable();
        ours.sort_unstable();
        assert!(!ours.is_empty());
        assert_eq!(ours, theirs, "frame {frame}: the inside moved");
    }
    // The skin is the same: its measures, and its VDBs but for the file's UUID.
    let fields = ["area", "volume", "band_nodes", "substeps"];
    for (a, b) in stats_lines(&whole.join("stats.jsonl"))
        .iter()
        .zip(stats_lines(&cut.join("stats.jsonl")))
    {
        for f in fields {
            assert_eq!(a[f], b[f], "{f}");
        }
        assert_eq!(b["manifold"], true, "{b}");
        assert_eq!(b["clean"], true, "{b}");
    }
    if cfg!(feature = "vdb") {
        for frame in [1, 6, 12] {
            let name = format!("s.{frame:04}.vdb");
            let (a, b) = (
                std::fs::read(whole.join(&name)).unwrap(),
                std::fs::read(cut.join(&name)).unwrap(),
            );
            assert_eq!(a[..21], b[..21]);
            assert_eq!(a[57..], b[57..], "frame {frame}: the skin VDB differs");
        }
    }
    // The USD shot holds the cut meshes.
    let layer = std::fs::read_to_string(cut.join("shot/shot.0012.usda")).unwrap_or_else(|_| {
        panic!("{:?}", common::names(&cut.join("shot")));
    });
    let b = read_mesh(&cut.join("m.0012.ply")).unwrap();
    let points = layer
        .lines()
        .skip_while(|l| !l.contains("point3f[] points"))
        .nth(1)
        .expect("points");
    assert_eq!(points.matches('(').count(), b.positions.len());
}

#[test]
fn a_region_that_holds_nothing_is_one_line() {
    let dir = scratch();
    let splash = data("splash/drop.####.ply");
    let mesh = dir.path().join("m.####.obj");
    for bad in [
        "1,2,3",
        "0,0,0,1,1,x",
        "0,0,0,0,1,1",
        "0,0,0,1,-1,1",
        "0,0,0,1,1,inf",
    ] {
        let out = activeskin(&[
            "particles",
            "--particles",
            &splash,
            "--radius",
            "0.04",
            "--frames",
            "1-2",
            "--mesh",
            mesh.to_str().unwrap(),
            "--region",
            bad,
        ]);
        assert_usage_error(&out, "--region");
    }
    assert!(
        common::names(dir.path()).is_empty(),
        "a refused run wrote files"
    );
}
