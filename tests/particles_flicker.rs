//! The skin's reason to exist (paper §1, §6.1): on a static cloud whose particles jitter
//! from frame to frame, the skin filters the noise in time, where surfacing each frame's
//! density on its own flickers (`activeskin::measure::flicker`). Goal (issue 6): ≥ 3×
//! less flicker at about the same accuracy.

use activeskin::measure::flicker;

#[test]
fn skin_flickers_three_times_less_than_per_frame_surfacing() {
    // Particles of radius 0.05, jittered by up to ±0.3 R, 16 frames, α = 4.
    let f = flicker::jittered_ball(0.05, 0.3, 16, 4.0);
    println!(
        "flicker: skin {:.4} voxel, per-frame {:.4} voxel ({:.1}× less); distance to the rest \
         surface: skin {:.3}, per-frame {:.3} voxel",
        f.skin,
        f.per_frame,
        f.per_frame / f.skin,
        f.skin_error,
        f.per_frame_error
    );
    assert!(f.skin * 3.0 <= f.per_frame, "{f:?}");
    assert!(f.skin_error <= 1.5 * f.per_frame_error, "{f:?}");
}
