//! OpenVDB point data grids as particle frames: positions (16-bit fixed point relative to
//! their voxel, as Houdini writes them) and `pscale` come back through the bridge; files
//! without points or cut short are one-line errors; `activeskin particles` skins them.
#![cfg(feature = "vdb")]

mod common;

use std::path::Path;

use common::{activeskin, Lcg};

use activeskin::io::particles;
use activeskin::vdb;
use glam::Vec3;

fn scattered(n: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut random = Lcg(seed);
    (0..n)
        .map(|_| [(); 3].map(|()| 2.0 * (random.next_f32() - 0.5) + 1.5))
        .collect()
}

#[test]
fn positions_and_pscale_round_trip_within_fixed_point() {
    let dir = common::scratch();
    let path = dir.path().join("points.vdb");
    let points = scattered(700, 3);
    let radii: Vec<f32> = (0..points.len()).map(|i| 0.01 + i as f32 * 1e-5).collect();
    let voxel = 0.1;
    vdb::write_points(&path, &points, Some(&radii), voxel, "points").unwrap();
    let read = particles::read(&path).unwrap();
    assert_eq!(read.positions.len(), points.len());
    let read_radii = read.radii.expect("pscale read as radius");
    // Points come back in voxel order: match each to its nearest original.
    let tolerance = voxel as f32 / 32768.0 * 1.5;
    for (p, r) in read.positions.iter().zip(&read_radii) {
        let (i, d) = points
            .iter()
            .enumerate()
            .map(|(i, q)| (i, p.distance(Vec3::from_array(*q))))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        assert!(d <= tolerance, "point {p} is {d} from the nearest original");
        assert_eq!(*r, radii[i]);
    }

    vdb::write_points(&path, &points, None, voxel, "points").unwrap();
    assert_eq!(particles::read(&path).unwrap().radii, None);

    // `info` lists it as usable input.
    let info = activeskin(&["info", path.to_str().unwrap()]);
    let listing = String::from_utf8_lossy(&info.stdout);
    assert!(info.status.success(), "{listing}");
    assert!(
        listing.contains("ptdataidx32") && listing.contains("700"),
        "{listing}"
    );
}

fn one_line_error(path: &Path) -> String {
    let err = particles::read(path).unwrap_err().to_string();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains(&path.display().to_string()), "{err}");
    err
}

#[test]
fn files_without_points_or_cut_short_are_one_line_errors() {
    let dir = common::scratch();
    let level_set = dir.path().join("sphere.vdb");
    let sphere = vdb::Grid::level_set_sphere(1.0, [0.0; 3], 0.1, 3.0).unwrap();
    let meta = vdb::FileMetadata {
        creator: "test".into(),
        has_frame: false,
        frame: 0,
    };
    vdb::write_grids(
        &level_set,
        &[(&sphere, vdb::WriteOptions::default())],
        &meta,
    )
    .unwrap();
    let err = one_line_error(&level_set);
    assert!(
        err.contains("no point data grid") && err.contains("float"),
        "{err}"
    );

    let path = dir.path().join("points.vdb");
    vdb::write_points(&path, &scattered(500, 5), None, 0.1, "points").unwrap();
    let bytes = std::fs::read(&path).unwrap();
    for tenth in 0..10 {
        let cut = dir.path().join(format!("cut{tenth}.vdb"));
        std::fs::write(&cut, &bytes[..bytes.len() * tenth / 10]).unwrap();
        one_line_error(&cut);
    }
}

#[test]
fn particles_command_skins_a_point_data_grid_sequence() {
    let dir = common::scratch();
    // A ball of particles on a lattice 0.05 apart.
    let ball: Vec<[f32; 3]> = (-8..=8)
        .flat_map(|x| (-8..=8).flat_map(move |y| (-8..=8).map(move |z| [x, y, z])))
        .map(|c| Vec3::from_array(c.map(|i| i as f32 * 0.05)))
        .filter(|p| p.length() <= 0.4)
        .map(|p| (p + Vec3::splat(1.5)).to_array())
        .collect();
    for frame in 1..=3 {
        let path = dir.path().join(format!("pts.{frame:04}.vdb"));
        vdb::write_points(&path, &ball, None, 0.05, "points").unwrap();
    }
    let out = dir.path().join("skin.####.vdb");
    let result = activeskin(&[
        "particles",
        "--particles",
        dir.path().join("pts.####.vdb").to_str().unwrap(),
        "--radius",
        "0.05",
        "--out",
        out.to_str().unwrap(),
        "-q",
    ]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let skin = vdb::Grid::read(&dir.path().join("skin.0003.vdb"), None).unwrap();
    let m = skin.measure_level_set().unwrap();
    // A ball of radius 0.4 dressed with particles of radius 0.05: about 0.4–0.45 across.
    let r = (3.0 * m.volume / (4.0 * std::f64::consts::PI)).cbrt();
    assert!((0.35..0.5).contains(&r), "skin radius {r}");
    let mesh = activeskin::validate::our_mesh(&skin).unwrap();
    assert_eq!(
        (mesh.components(), mesh.euler_characteristic()),
        (1, 2),
        "one sphere (OpenVDB's measure says χ = {})",
        m.euler_characteristic
    );
}

#[test]
fn particles_use_their_own_pscale_unless_told_not_to() {
    let dir = common::scratch();
    let centres = [[1.0f32, 1.5, 1.5], [2.0, 1.5, 1.5]];
    let radii = [0.1f32, 0.2];
    for frame in 1..=2 {
        let path = dir.path().join(format!("two.{frame:04}.vdb"));
        vdb::write_points(&path, &centres, Some(&radii), 0.05, "points").unwrap();
    }
    // The mean distance of the skin's vertices to the nearer centre, for each centre.
    let sizes = |extra: &[&str]| {
        let out = dir.path().join("skin.####.obj");
        let input = dir.path().join("two.####.vdb");
        let mut args = vec![
            "particles",
            "--particles",
            input.to_str().unwrap(),
            "--radius",
            "0.1",
            "--voxel-size",
            "0.025",
            // Lone particles: a kernel of two radii, its surface at W(1/2), a radius out.
            "--smoothing-length",
            "1",
            "--iso",
            "0.421875",
            "--alpha",
            "24",
            "--mesh",
            out.to_str().unwrap(),
            "-q",
        ];
        args.extend_from_slice(extra);
        let result = activeskin(&args);
        assert!(
            result.status.success(),
            "{}",
            String::from_utf8_lossy(&result.stderr)
        );
        let obj = std::fs::read_to_string(dir.path().join("skin.0002.obj")).unwrap();
        let mut sums = [(0.0f32, 0usize); 2];
        for line in obj.lines().filter_map(|l| l.strip_prefix("v ")) {
            let v: Vec<f32> = line
                .split_whitespace()
                .map(|w| w.parse().unwrap())
                .collect();
            let p = Vec3::new(v[0], v[1], v[2]);
            let k = usize::from(p.x > 1.5);
            sums[k].0 += p.distance(Vec3::from_array(centres[k]));
            sums[k].1 += 1;
        }
        sums.map(|(sum, n)| sum / n as f32)
    };
    let own = sizes(&[]);
    for (size, radius) in own.iter().zip(radii) {
        assert!((size - radius).abs() < 0.025, "{own:?}");
    }
    let uniform = sizes(&["--ignore-radii"]);
    println!("skin radii: own pscale {own:?} (0.1, 0.2), --ignore-radii {uniform:?} (0.1, 0.1)");
    for size in uniform {
        assert!((size - 0.1).abs() < 0.025, "{uniform:?}");
    }
}

#[test]
fn velocities_v_come_back_and_carry_the_skin() {
    // Houdini's `v` point attribute: read exactly, in point order with the positions.
    let dir = common::scratch();
    let points = scattered(300, 7);
    let velocities: Vec<[f32; 3]> = points.iter().map(|p| [p[1], -p[0], 0.25]).collect();
    let path = dir.path().join("v.vdb");
    vdb::write_points_with_velocities(&path, &points, None, Some(&velocities), 0.1, "points")
        .unwrap();
    let read = particles::read(&path).unwrap();
    let got = read.velocities.expect("v read");
    for (p, v) in read.positions.iter().zip(&got) {
        // Each velocity is the one written for (within fixed point) this position.
        let expected = Vec3::new(p.y, -p.x, 0.25);
        assert!((*v - expected).length() < 2e-3, "{v} vs {expected}");
    }

    // A ball of points moving 4 voxels a frame, as VDB points with `v`: carried.
    let (radius, dx) = (0.05f32, 0.025f32);
    let speed = 4.0 * dx * 24.0;
    let mut ball = Vec::new();
    for i in -3i32..=3 {
        for j in -3i32..=3 {
            for k in -3i32..=3 {
                let p = Vec3::new(i as f32, j as f32, k as f32) * 2.0 * radius;
                if p.length() <= 0.3 {
                    ball.push(p);
                }
            }
        }
    }
    for frame in 1..=5 {
        let shift = Vec3::X * speed * (frame - 1) as f32 / 24.0 + Vec3::splat(1.0);
        let at: Vec<[f32; 3]> = ball.iter().map(|p| (*p + shift).to_array()).collect();
        let v = vec![[speed, 0.0, 0.0]; at.len()];
        let path = dir.path().join(format!("p.{frame:04}.vdb"));
        vdb::write_points_with_velocities(&path, &at, None, Some(&v), 0.05, "points").unwrap();
    }
    let pattern = dir.path().join("p.####.vdb").to_string_lossy().into_owned();
    let centre_x = |extra: &[&str]| {
        let out = common::scratch();
        let mesh = out.path().join("s.####.obj").to_string_lossy().into_owned();
        let mut args = vec![
            "particles",
            "--particles",
            &pattern,
            "--radius",
            "0.05",
            "--mesh",
            &mesh,
            "-q",
        ];
        args.extend_from_slice(extra);
        common::assert_ok(&activeskin(&args));
        let mesh = common::read_mesh(&out.path().join("s.0005.obj")).unwrap();
        mesh.positions.iter().map(|p| p.x).sum::<f32>() / mesh.positions.len() as f32
    };
    let expected = 1.0 + speed * 4.0 / 24.0;
    let (carried, attracted) = (centre_x(&[]), centre_x(&["--no-velocity"]));
    assert!(
        (carried - expected).abs() < 0.5 * dx,
        "{carried} vs {expected}"
    );
    assert!(expected - attracted > 2.0 * dx, "{attracted} vs {expected}");
}
