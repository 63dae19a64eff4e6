//! Band nodes per second for a full step (speed, update, band upkeep, renormalisation,
//! polygonization) on a sphere of radius 100 voxels, moving toward a sphere of radius 104.
//! `cargo bench --bench step` (RAYON_NUM_THREADS to pick the thread count, BENCH_STEPS the
//! number of timed steps, e.g. 2 under `valgrind --tool=callgrind`).

use std::time::Instant;

use activeskin::skin::{Skin, SkinParams, SpeedParams};
use activeskin::target::Sphere;
use glam::Vec3;

fn main() {
    let dx = 0.01;
    let sphere = |r: f32| Sphere {
        center: Vec3::ZERO,
        radius: r,
    };
    let params = SkinParams {
        dx,
        speed: SpeedParams {
            alpha: 2.0,
            beta: 0.001,
            ..SpeedParams::default()
        },
        ..SkinParams::default()
    };
    let mut skin: Skin<f32> = Skin::new(&sphere(100.0 * dx), params);
    let target = sphere(104.0 * dx);
    let dt = skin.stable_dt(&target);
    skin.step(&target, dt); // warm the buffers
    let steps: usize = std::env::var("BENCH_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let mut nodes = 0usize;
    let start = Instant::now();
    for _ in 0..steps {
        nodes += skin.grid().active_node_count();
        skin.step(&target, dt);
    }
    let seconds = start.elapsed().as_secs_f64();
    println!(
        "sphere r=100 voxels: {} blocks, {} band nodes, {:.1} ms per step, {:.2} M band nodes/s ({} threads)",
        skin.grid().block_count(),
        nodes / steps,
        seconds * 1e3 / steps as f64,
        nodes as f64 / seconds / 1e6,
        rayon::current_num_threads()
    );
}
