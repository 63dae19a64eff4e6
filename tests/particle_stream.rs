//! Particles handed over frame by frame ([`ParticleStream`], what the Python API runs)
//! make the same surfaces as `activeskin particles` on the same particles in files:
//! the meshes, their velocities and attributes written byte for byte alike. Bad
//! particles end the stream with the command's message; later frames say it stopped.

mod common;

use std::path::Path;

use activeskin::frames::{AttributeChoice, ParticleInput, ParticleStream, StreamSpec};
use activeskin::io::mesh::{write_with_values, VertexValues};
use activeskin::particles::{Attribute, Particles};
use activeskin::skin::Physics;
use common::{activeskin, assert_ok, scratch};
use glam::Vec3;

const R: f32 = 0.02;

/// A ball of particles 2r apart, moving and squashing a little each frame, ids in a
/// shuffled order, each carrying `temperature` = 300 + 50 x.
fn frame(frame: i64) -> Particles {
    let mut positions = Vec::new();
    for x in -5i32..=5 {
        for y in -5i32..=5 {
            for z in -5i32..=5 {
                if x * x + y * y + z * z <= 25 {
                    let p = Vec3::new(x as f32, y as f32, z as f32) * 2.0 * R;
                    let squash = Vec3::new(1.0, 1.0 - 0.02 * frame as f32, 1.0);
                    positions.push(p * squash + Vec3::X * (0.03 * frame as f32));
                }
            }
        }
    }
    let n = positions.len();
    // Reversed on odd frames: matched by id, not by order.
    let order: Vec<usize> = match frame % 2 {
        0 => (0..n).collect(),
        _ => (0..n).rev().collect(),
    };
    Particles {
        positions: order.iter().map(|&i| positions[i]).collect(),
        ids: Some(order.iter().map(|&i| i as i64).collect()),
        attributes: vec![Attribute {
            name: "temperature".into(),
            components: 1,
            values: order
                .iter()
                .map(|&i| 300.0 + 50.0 * positions[i].x)
                .collect(),
        }],
        ..Particles::default()
    }
}

fn spec() -> StreamSpec {
    let particles = ParticleInput {
        attributes: AttributeChoice::Named(vec!["temperature".into()]),
        ..ParticleInput::with_radius(R)
    };
    let dx = particles.dx;
    StreamSpec {
        // The command's policy: a particle skin's defaults (its smoothing among them).
        params: Physics::default().particle_params(R, dx),
        particles,
        fps: 24.0,
        hold_volume: true,
        velocities: true,
        velocity_grid: false,
        first_frame: 1,
        reference: None,
        region: None,
        collider: None,
    }
}

#[test]
fn handed_frames_make_the_commands_meshes_byte_for_byte() {
    let data = scratch();
    for f in 1..=5 {
        activeskin::io::ply::write_particles(&data.path().join(format!("p.{f:04}.ply")), &frame(f))
            .unwrap();
    }
    let cli = scratch();
    let pattern = data.path().join("p.####.ply");
    let meshes = cli.path().join("m.####.ply");
    assert_ok(&activeskin(&[
        "particles",
        "--particles",
        pattern.to_str().unwrap(),
        "--radius",
        &R.to_string(),
        "--attribute",
        "temperature",
        "--mesh",
        meshes.to_str().unwrap(),
        "-q",
    ]));

    let ours = scratch();
    let mut stream = ParticleStream::start(spec()).unwrap();
    for f in 1..=5 {
        // Read back from the same files, as the command reads them.
        let particles =
            activeskin::io::particles::read(&data.path().join(format!("p.{f:04}.ply"))).unwrap();
        let surface = stream.advance(particles).unwrap();
        assert_eq!(surface.frame, f);
        assert!(surface.mesh.positions.len() > 1000);
        assert_eq!(surface.attributes.len(), 1);
        let values = VertexValues {
            velocities: surface.velocities.as_deref(),
            attributes: &surface.attributes,
        };
        let path = ours.path().join(format!("m.{f:04}.ply"));
        write_with_values(&surface.mesh, values, &path).unwrap();
        let read = |p: &Path| std::fs::read(p).unwrap();
        assert!(
            read(&path) == read(&cli.path().join(format!("m.{f:04}.ply"))),
            "frame {f} differs from the command's"
        );
    }
}

#[test]
fn bad_particles_stop_the_stream_with_the_commands_message() {
    let mut stream = ParticleStream::start(spec()).unwrap();
    stream.advance(frame(1)).unwrap();
    let mut bad = frame(2);
    bad.attributes.clear();
    let error = stream.advance(bad).unwrap_err().to_string();
    assert!(
        error.contains("no particle attribute 'temperature'"),
        "{error}"
    );
    let later = stream.advance(frame(3)).unwrap_err().to_string();
    assert!(later.contains("stopped"), "{later}");
}

#[test]
fn parameters_that_cannot_make_a_skin_are_refused_at_the_start() {
    let mut spec = spec();
    spec.particles.radius = -1.0;
    let error = ParticleStream::start(spec).err().unwrap().to_string();
    // The field as the library names it; each front end says it its own way.
    assert!(
        error.contains("`radius` must be a positive number") && !error.contains("--"),
        "{error}"
    );
}
