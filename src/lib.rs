//! # activeskin
//!
//! Active implicit skins (Desbrun & Cani, 1997) for moving targets: a potential on a
//! block-sparse grid whose zero isosurface is attracted to a target (VDB level set or fog
//! volume, particles, analytic shape) while behaving like a membrane with surface tension.
//!
//! Layers, arrows pointing down only (checked by `tests/layers.rs`):
//!
//! - **core**, pure Rust, built and tested without OpenVDB (`--no-default-features`):
//!   [`grid`] (§4.1–4.2), `stencil` (§4.4), [`skin`] (§4.3, §4.5, §4.7–4.8, §5),
//!   [`polygonize`] (§3.2, §4.6), [`mesh`], [`flow`] (§7), [`target`] (§3.4, and the
//!   particle density of §6.1), [`volume`] (a VDB grid's plain data), [`particles`],
//!   [`render`], [`budget`];
//! - **files**: [`io`], one module per format (particles in PLY, VTK, VTU, BGEO, JSON,
//!   text; meshes in OBJ and PLY; images in EXR and PNG; OpenVDB through the C++ bridge,
//!   [`io::vdb`], with the default feature `vdb`), atomic writes; [`sequence`] (frame
//!   patterns);
//! - **the frame loop**, [`frames`]: inputs, advance, canonical state, outputs, resume,
//!   and the policy every front end shares (warm-up, velocity scale); [`measure`] and
//!   [`validate`] (feature `vdb`), the measurements of benchmarks and checks;
//! - the command line on top (the `activeskin` binary, feature `cli`).
//!
//! A skin morphing a sphere into a torus, its mesh a clean surface:
//!
//! ```
//! use activeskin::skin::{Skin, SkinParams, SpeedParams};
//! use activeskin::target::{Sphere, Torus};
//! use glam::Vec3;
//!
//! let dx = 1.0 / 24.0;
//! let params = SkinParams { dx, speed: SpeedParams::default_for(dx, 4.0), ..SkinParams::default() };
//! let sphere = Sphere { center: Vec3::ZERO, radius: 0.5 };
//! let torus = Torus { center: Vec3::ZERO, major: 0.5, minor: 0.2 };
//! let mut skin: Skin<f32> = Skin::new(&sphere, params);
//! for _frame in 0..48 {
//!     skin.advance(&torus, 1.0 / 24.0); // one frame at 24 fps
//! }
//! let check = skin.mesh().check();
//! assert!(check.is_clean(), "{check}");
//! assert_eq!(skin.mesh().euler_characteristic(), 0); // a torus
//! ```

pub mod budget;
pub mod field;
pub mod flow;
pub mod frames;
pub mod grid;
pub mod io;
pub mod measure;
pub mod mesh;
pub mod particles;
pub mod polygonize;
pub mod render;
pub mod sequence;
pub mod skin;
mod stencil;
pub mod target;
#[cfg(feature = "vdb")]
pub mod validate;
#[cfg(feature = "vdb")]
pub use io::vdb;
pub mod volume;

/// Every error of the library: the frame loop's, which wraps each stage's (grids, meshes,
/// skins, patterns, renders, particles, VDB files) with `#[from]`, so that `?` on any
/// stage's error works in a caller returning this one.
pub use frames::FrameError as Error;

/// A repeatable pseudo-random source for tests: `below(n)` in 0..n (a 64-bit LCG's high
/// bits).
#[cfg(test)]
pub(crate) fn test_rng(seed: u64) -> impl FnMut(u64) -> u64 {
    let mut state = seed;
    move |n| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) % n
    }
}
