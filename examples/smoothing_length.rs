//! How the smoothing length was chosen (issue 13): on a fluid at rest — 100 k particles
//! of radius r on a lattice of spacing 2r filling a ball, jittered by up to ±0.15 r anew
//! every frame — the skin at the `particles` command's defaults and cell = r, for several
//! smoothing lengths: mean distance to the true surface (the sphere holding the
//! particles' share of the lattice), flicker (mean distance between consecutive frames'
//! surfaces) and time per frame. `cargo run --release --example smoothing_length`.

use std::time::Instant;

use activeskin::measure::flicker::jittered;
use activeskin::mesh::{mean_distance, Mesh};
use activeskin::skin::{Skin, SkinParams, SpeedParams};
use activeskin::target::{fluid_iso, Density, DensityGrid};
use glam::{IVec3, Vec3};

fn main() {
    let (r, frames) = (0.005f32, 10u64);
    let spacing = 2.0 * r;
    let k = 30;
    let lattice: Vec<Vec3> = (-k..=k)
        .flat_map(|x| (-k..=k).flat_map(move |y| (-k..=k).map(move |z| IVec3::new(x, y, z))))
        .map(|c| c.as_vec3() * spacing)
        .filter(|p| p.length() <= 0.288)
        .collect();
    let true_radius = spacing * (3.0 * lattice.len() as f32 / (4.0 * std::f32::consts::PI)).cbrt();
    println!("{} particles, cell = r", lattice.len());
    println!("smoothing length   distance to the true surface   flicker   ms/frame");
    for l in [1.5f32, 2.0, 2.5, 3.0] {
        let target = |frame: u64| {
            let density = Density::new(
                jittered(&lattice, frame, 0.15 * r),
                2.0 * l * r,
                fluid_iso(l),
            )
            .normalized(l);
            DensityGrid::rasterize(&density, r)
        };
        let params = SkinParams {
            dx: r,
            speed: SpeedParams::default_for(r, 4.0),
            ..SkinParams::default()
        };
        let mut first = target(0);
        first.fill_voids(4.0 / 3.0 * std::f32::consts::PI * (2.0 * l * r).powi(3));
        let mut skin: Skin<f32> = Skin::new(&first, params);
        let mut meshes: Vec<Mesh> = Vec::new();
        let start = Instant::now();
        for frame in 1..frames {
            let grid = target(frame);
            skin.advance(&grid, 1.0 / 24.0);
            skin.seed(&grid);
            skin.settle();
            meshes.push(skin.mesh().clone());
        }
        let ms = start.elapsed().as_secs_f64() * 1e3 / (frames - 1) as f64;
        let settled = &meshes[1..];
        let distance = settled
            .iter()
            .map(|m| {
                m.positions
                    .iter()
                    .map(|p| f64::from((p.length() - true_radius).abs()))
                    .sum::<f64>()
                    / m.positions.len() as f64
            })
            .sum::<f64>()
            / settled.len() as f64
            / f64::from(r);
        let flicker = settled
            .windows(2)
            .map(|pair| mean_distance(&pair[1], &pair[0], r))
            .sum::<f64>()
            / (settled.len() - 1) as f64
            / f64::from(r);
        println!("{l:>16}   {distance:>20.3} voxel   {flicker:>7.4}   {ms:>8.0}");
    }
}
