//! `--collider` (issue 51): a block of liquid resting in the corner of a tank, its
//! particles three radii off the walls and the floor (its surface about a radius off them,
//! as an SPH solver's boundary leaves it). Without a collider
//! its skin closes into a shell about a radius off each wall; with the tank as collider
//! (a closed OBJ mesh of its walls) the surface meets the walls — points of the walls
//! where the liquid rests against them are inside the mesh — and goes no deeper into them
//! than `--collider-depth`; the mesh stays a clean closed surface, and the skin (its
//! measured volume) is the same.
#![cfg(feature = "cli")]

mod common;

use std::path::Path;

use activeskin::mesh::Mesh;
use activeskin::particles::Particles;
use common::{activeskin, scratch};
use common::{particle_shot, stats_lines};
use glam::Vec3;

const R: f32 = 0.01;

/// Particles 2r apart filling x, z ∈ [3r, 0.2], y ∈ [3r, 0.1]: the corner of a tank whose
/// inside is x, y, z ≥ 0.
fn block() -> Particles {
    let mut positions = Vec::new();
    let n = |to: f32| ((to - 3.0 * R) / (2.0 * R)).round() as i32;
    for i in 0..=n(0.2) {
        for j in 0..=n(0.1) {
            for k in 0..=n(0.2) {
                positions
                    .push(Vec3::new(i as f32, j as f32, k as f32) * 2.0 * R + Vec3::splat(3.0 * R));
            }
        }
    }
    Particles {
        positions,
        ..Particles::default()
    }
}

/// The tank's floor and walls as one closed OBJ: five boxes 0.05 thick around the inside
/// [0, 0.4]³, open at the top.
fn tank(path: &Path) {
    let t = 0.05;
    let boxes = [
        (Vec3::new(-t, -t, -t), Vec3::new(0.4 + t, 0.0, 0.4 + t)),
        (Vec3::new(-t, -t, -t), Vec3::new(0.0, 0.4, 0.4 + t)),
        (Vec3::new(0.4, -t, -t), Vec3::new(0.4 + t, 0.4, 0.4 + t)),
        (Vec3::new(-t, -t, -t), Vec3::new(0.4 + t, 0.4, 0.0)),
        (Vec3::new(-t, -t, 0.4), Vec3::new(0.4 + t, 0.4, 0.4 + t)),
    ];
    let mut mesh = Mesh::default();
    for (lo, hi) in boxes {
        let base = mesh.positions.len() as u32;
        for c in 0..8 {
            let pick = |bit: u32, a: f32, b: f32| if c & bit == 0 { a } else { b };
            mesh.positions.push(Vec3::new(
                pick(1, lo.x, hi.x),
                pick(2, lo.y, hi.y),
                pick(4, lo.z, hi.z),
            ));
        }
        // Outward, counter-clockwise seen from outside.
        for q in [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ] {
            mesh.triangles.push([base + q[0], base + q[1], base + q[2]]);
            mesh.triangles.push([base + q[0], base + q[2], base + q[3]]);
        }
    }
    mesh.normals = vec![Vec3::Y; mesh.positions.len()];
    activeskin::io::obj::write(&mesh, path).unwrap();
}

/// Whether `p` is inside the closed `mesh`: crossings of a ray from it, odd.
fn inside(mesh: &Mesh, p: Vec3) -> bool {
    let d = Vec3::new(0.577, 0.613, 0.539).normalize();
    let mut crossings = 0;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let h = d.cross(e2);
        let det = e1.dot(h);
        if det.abs() < 1e-12 {
            continue;
        }
        let s = p - a;
        let u = s.dot(h) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        if u < 0.0 || v < 0.0 || u + v > 1.0 {
            continue;
        }
        if e2.dot(q) / det > 0.0 {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}

#[test]
fn the_liquid_meets_the_tanks_walls_and_floor() {
    let dir = scratch();
    let cup = dir.path().join("tank.obj");
    tank(&cup);
    let (plain, met) = (dir.path().join("plain"), dir.path().join("met"));
    for d in [&plain, &met] {
        std::fs::create_dir_all(d).unwrap();
    }
    let stats = |d: &Path| d.join("stats.jsonl").to_str().unwrap().to_owned();
    let (sp, sm) = (stats(&plain), stats(&met));
    let depth = 0.002;
    let a = particle_shot(&plain, 2, |_| block(), R, &["--stats", &sp]);
    let b = particle_shot(
        &met,
        2,
        |_| block(),
        R,
        &[
            "--stats",
            &sm,
            "--collider",
            cup.to_str().unwrap(),
            "--collider-depth",
            &depth.to_string(),
        ],
    );
    // Where the liquid rests against the walls and the floor, the walls' faces are inside
    // the liquid now, not a shell off them: along each face, up to the edges where two
    // of them meet (within 3.3 r of the floor), not within 8 r of the corner where three
    // meet, which keeps a rounding.
    let mut contact = Vec::new();
    // Off the voxels' planes, so that the ray test meets no edge of the mesh head on.
    for u in [0.083, 0.123, 0.163] {
        for v in [0.033, 0.063] {
            contact.push(Vec3::new(0.0, v, u)); // the wall x = 0
            contact.push(Vec3::new(u, v, 0.0)); // the wall z = 0
        }
        for v in [0.083, 0.133, 0.183] {
            contact.push(Vec3::new(u, 0.0, v)); // the floor
        }
    }
    for p in &contact {
        assert!(
            !inside(&a[1], *p),
            "{p}: inside the liquid without a collider"
        );
        assert!(
            inside(&b[1], *p),
            "{p}: the liquid does not meet the tank there"
        );
    }
    // No deeper into the walls than the depth asked (half a voxel of meshing slack).
    let deepest = b[1]
        .positions
        .iter()
        .map(|p| -p.x.min(p.y).min(p.z))
        .fold(f32::MIN, f32::max);
    assert!(deepest <= depth + 0.5 * R, "{deepest} into the walls");
    assert!(
        deepest >= depth - 0.5 * R,
        "{deepest}: not carried into the walls"
    );
    // The skin is the same: its volume, measured as each frame settles.
    for (x, y) in stats_lines(Path::new(&sp))
        .iter()
        .zip(stats_lines(Path::new(&sm)))
    {
        assert_eq!(x["volume"], y["volume"]);
        assert_eq!(y["manifold"], true);
    }
    // The shell's gap filled: more liquid in the mesh, by about the contact patches times
    // the gap, not more.
    let (va, vb) = (a[1].volume(), b[1].volume());
    let patches = 0.2 * 0.1 * 2.0 + 0.2 * 0.2;
    assert!(
        vb > va && vb - va < patches * 2.5 * f64::from(R),
        "{va} → {vb}"
    );
}

#[test]
fn a_collider_that_cannot_be_read_is_one_line() {
    let dir = scratch();
    let bad = dir.path().join("tank.stl");
    std::fs::write(&bad, "solid").unwrap();
    let missing = dir.path().join("none.obj");
    let particles = dir.path().join("p.0001.ply");
    activeskin::io::ply::write_particles(&particles, &block()).unwrap();
    let input = dir.path().join("p.####.ply");
    let mesh = dir.path().join("m.####.obj");
    let run = |collider: &Path| {
        activeskin(&[
            "particles",
            "--particles",
            input.to_str().unwrap(),
            "--radius",
            "0.01",
            "--mesh",
            mesh.to_str().unwrap(),
            "--collider",
            collider.to_str().unwrap(),
            "-q",
        ])
    };
    common::assert_usage_error(&run(&bad), "--collider");
    common::assert_one_line_error(&run(&missing), "none.obj");
}
