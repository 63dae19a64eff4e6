//! PLY, VTK, VTK XML, BGEO, JSON and XYZ/CSV particle files from arbitrary bytes: errors, never panics, and what
//! is accepted is finite.
#![no_main]

use activeskin::io::particles::{parse, FORMATS};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    for format in FORMATS {
        if let Ok(particles) = parse(data, format) {
            assert!(particles.positions.iter().all(|p| p.is_finite()));
            if let Some(radii) = &particles.radii {
                assert_eq!(radii.len(), particles.positions.len());
            }
        }
    }
});
