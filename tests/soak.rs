//! Soak (issue 7): 10 000 solver sub-steps against targets that never stop changing —
//! unions of up to four spheres wandering, growing and shrinking in a box, so the skin
//! splits and merges over and over. Nothing may go NaN or infinite, the band and the
//! block arena must stay bounded (no leak: the second half of the run uses no more than
//! the first half, give or take), the process's memory must stay flat, and χ must stay
//! consistent with the component count. `cargo test --release --test soak -- --ignored
//! --nocapture` (about a minute on 2 cores).
#![cfg(feature = "vdb")]

mod common;

use activeskin::skin::{Skin, SkinParams, SpeedParams};
use activeskin::target::{Sphere, Target, Union};
use common::Lcg;
use glam::Vec3;

/// Resident memory of this process, bytes (Linux).
fn resident_bytes() -> usize {
    let statm = std::fs::read_to_string("/proc/self/statm").unwrap_or_default();
    let pages: usize = statm
        .split_whitespace()
        .nth(1)
        .and_then(|p| p.parse().ok())
        .unwrap_or(0);
    pages * 4096
}

/// A sphere on a smooth random path: centre and radius are sums of two sinusoids.
struct Wanderer {
    phase: [f32; 8],
    speed: [f32; 8],
}

impl Wanderer {
    fn new(random: &mut Lcg) -> Self {
        Wanderer {
            phase: std::array::from_fn(|_| random.next_f32() * std::f32::consts::TAU),
            speed: std::array::from_fn(|_| 0.3 + 1.2 * random.next_f32()),
        }
    }

    fn at(&self, t: f32) -> Sphere {
        let wave = |k: usize| (self.speed[k] * t + self.phase[k]).sin();
        Sphere {
            center: Vec3::new(
                0.45 * wave(0) + 0.15 * wave(1),
                0.45 * wave(2) + 0.15 * wave(3),
                0.45 * wave(4) + 0.15 * wave(5),
            ),
            radius: 0.3 + 0.1 * wave(6) + 0.05 * wave(7),
        }
    }
}

#[test]
#[ignore = "soak: about a minute; run with --ignored"]
fn ten_thousand_steps_against_changing_targets() {
    let mut random = Lcg(2024);
    let wanderers: Vec<Wanderer> = (0..4).map(|_| Wanderer::new(&mut random)).collect();
    let target_at = |t: f32| {
        // Between one and four spheres: the count itself changes every few seconds.
        let count = 1 + ((t * 0.37).sin() * 1.6 + 1.6).round() as usize;
        Union(
            wanderers[..count.min(4)]
                .iter()
                .map(|w| Box::new(w.at(t)) as Box<dyn Target>)
                .collect(),
        )
    };
    let mut skin: Skin<f32> = Skin::new(
        &target_at(0.0),
        SkinParams {
            dx: 1.0 / 24.0,
            speed: SpeedParams {
                alpha: 12.0,
                beta: 0.001,
                ..SpeedParams::default()
            },
            ..SkinParams::default()
        },
    );

    let mut substeps = 0u64;
    let mut frame = 0u32;
    // Per half of the run: largest band, blocks, arena bytes and resident memory.
    let mut peaks = [[0usize; 4]; 2];
    let mut splits_or_merges = 0;
    let mut last_components = 1;
    let mut chi_matches = 0u32;
    let rss_start = resident_bytes();
    while substeps < 10_000 {
        frame += 1;
        let time = frame as f32 / 24.0;
        let stats = skin.advance(&target_at(time), 1.0 / 24.0);
        substeps += u64::from(stats.substeps);

        let finite = skin.grid().stored_values().all(f32::is_finite);
        assert!(finite, "frame {frame}: a NaN or infinite potential");
        assert!(
            stats.area.is_finite() && stats.volume.is_finite(),
            "frame {frame}: {stats:?}"
        );
        // Closed surfaces: χ = 2·(components − handles), so even and at most 2 per
        // component; spheres wandering about give handles only fleetingly.
        let chi = stats.euler_characteristic;
        assert!(
            chi % 2 == 0 && chi <= 2 * stats.components as i64,
            "frame {frame}: χ = {chi} with {} components",
            stats.components
        );
        if chi == 2 * stats.components as i64 {
            chi_matches += 1;
        }
        if stats.components != last_components {
            splits_or_merges += 1;
            last_components = stats.components;
        }
        let half = usize::from(substeps >= 5_000);
        let now = [
            stats.band_nodes,
            stats.blocks,
            skin.memory_bytes(),
            resident_bytes(),
        ];
        for (peak, value) in peaks[half].iter_mut().zip(now) {
            *peak = (*peak).max(value);
        }
    }
    println!(
        "soak: {substeps} sub-steps over {frame} frames ({:.0} s of animation); \
         {splits_or_merges} splits or merges; χ = 2·components on {:.1} % of frames",
        frame as f32 / 24.0,
        100.0 * chi_matches as f32 / frame as f32
    );
    for (name, k) in [
        ("band nodes", 0),
        ("blocks", 1),
        ("arena bytes", 2),
        ("resident bytes", 3),
    ] {
        println!(
            "soak: peak {name}: first half {}, second half {}",
            peaks[0][k], peaks[1][k]
        );
    }
    println!("soak: resident memory at start {rss_start}");
    assert!(splits_or_merges >= 10, "the targets must split and merge");
    assert!(chi_matches as f32 >= 0.95 * frame as f32);
    // No leak: the second half's peaks stay within the first half's, give or take the
    // shapes the second half happens to visit (a quarter).
    for (name, k) in [
        ("band nodes", 0),
        ("blocks", 1),
        ("arena bytes", 2),
        ("resident bytes", 3),
    ] {
        assert!(
            peaks[1][k] as f64 <= 1.25 * peaks[0][k] as f64,
            "{name}: {} then {}",
            peaks[0][k],
            peaks[1][k]
        );
    }
}
