//! The normal speed of the skin (paper §3.4, eq. 2–3, §4.3, §5):
//! `V = α (G(X̃) − iso) − β κ + γ_A (A0 − A)/A0 + γ_V (V0 − Vol)/V0`.

use glam::{IVec3, Vec3};

use crate::polygonize::LocalCrossings;

use crate::grid::IndexToWorld;
use crate::stencil::Stencil;

/// Where the attraction term reads the target (§4.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AttractionSample {
    /// At the average of the last mesh's crossing points on the node's incident edges
    /// (§4.3.2); nodes without one use their projection onto the skin.
    #[default]
    Crossings,
    /// At the node itself: the naive choice of §4.3.1, which oscillates forever.
    Node,
}

/// The physical parameters of the skin.
#[derive(Debug, Clone, Copy)]
pub struct SpeedParams {
    /// Attraction rate α (1/s): the skin moves at α × its distance to the target.
    pub alpha: f32,
    /// Surface tension β (world units²/s): speed −βκ.
    pub beta: f32,
    /// Area preservation gain γ_A (world units/s).
    pub area_gain: f32,
    /// Volume preservation gain γ_V (world units/s).
    pub volume_gain: f32,
    /// Where the attraction reads its target (§4.3).
    pub attraction: AttractionSample,
    /// The farthest target distance the attraction reads (world units): a skin farther
    /// from its target closes the gap at α × this. Unbounded by default; particles bound
    /// it ([`PARTICLE_REACH_RADII`]).
    pub reach: f32,
}

/// The attraction's reach on particles, in particle radii: a density's first-order
/// distance (iso − G)/|∇G| is a guess where its kernel (4 radii) fades, and is capped at
/// the kernel's radius; capped here instead, the fastest attraction, α × 2.5 r, lets a
/// sub-step span 1/20 s at cell = r (§4.8's CFL bound with the default α and safety),
/// so a frame at 24 fps takes one sub-step where it took two. On the SPlisHSPlasH dam
/// breaks that is 0.92× the CPU for bumps 1 % higher (docs/benchmarks.md, 2026-12-07).
pub const PARTICLE_REACH_RADII: f32 = 2.5;

/// Default attraction rate α, 1/s.
pub const DEFAULT_ALPHA: f32 = 4.0;

/// Default surface tension: β = this × α × Δx². Per voxel, tension smooths the same
/// number of voxels whatever the cell; per α, its explicit step bound Δx²/(6β) = 4/(3α)
/// stays above the attraction's own 1/α (§4.8), so the default tension never adds a
/// sub-step; and its rest offset on a sphere of R voxels, 2β/(αR) = 1/(4R) voxel, stays
/// under the skin's other errors. (8 Δx²/s whatever α, tried first, shrank a sphere of
/// 8 voxels by half a voxel at α = 4.)
pub const DEFAULT_TENSION_PER_ALPHA: f32 = 0.125;

impl SpeedParams {
    /// The defaults on voxels of size `dx` with attraction `alpha`: β =
    /// [`DEFAULT_TENSION_PER_ALPHA`]·α·Δx².
    pub fn default_for(dx: f32, alpha: f32) -> Self {
        SpeedParams {
            alpha,
            beta: DEFAULT_TENSION_PER_ALPHA * alpha * dx * dx,
            ..SpeedParams::default()
        }
    }
}

impl Default for SpeedParams {
    /// α = [`DEFAULT_ALPHA`], no tension, no preservation.
    fn default() -> Self {
        SpeedParams {
            alpha: DEFAULT_ALPHA,
            beta: 0.0,
            area_gain: 0.0,
            volume_gain: 0.0,
            attraction: AttractionSample::Crossings,
            reach: f32::INFINITY,
        }
    }
}

/// Terms of V that are the same at every node in a step.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct GlobalTerms {
    /// γ_A (A0 − A)/A0 + γ_V (V0 − Vol)/V0
    pub preservation: f32,
}

impl GlobalTerms {
    pub(crate) fn new(params: &SpeedParams, area: (f64, f64), volume: (f64, f64)) -> Self {
        let relative = |(now, rest): (f64, f64)| {
            if rest.abs() > 0.0 {
                ((rest - now) / rest) as f32
            } else {
                0.0
            }
        };
        GlobalTerms {
            preservation: params.area_gain * relative(area) + params.volume_gain * relative(volume),
        }
    }
}

/// What the speed of one node needs to know about where it is.
pub(crate) struct NodeContext {
    /// Global index of the node.
    pub ijk: IVec3,
    /// Its coordinates inside its block (0..8), for crossing lookups.
    pub local: IVec3,
    /// Index space to world.
    pub xf: IndexToWorld,
    /// Half-width w of the tube, voxels.
    pub band_width: f32,
    /// |f| from which the step's renormalisation remakes a node from the nodes nearer the
    /// skin ([`REMADE_BEYOND_VOXELS`] / w; infinite without renormalisation).
    pub remade_beyond: f32,
}

/// How far from the skin (voxels) a node's attraction is read when the renormalisation
/// follows each step. Beyond, the sweep remakes the node from the nodes nearer the skin
/// (the upwind ones), whose motion is the skin's: what the attraction gave it there would
/// only reach the layer outside it, a step late. Reading the target there was about half
/// of its evaluations (a projection each); two voxels leave the dam breaks' look the same
/// to the second digit (bumps, particles outside) for 3 % less CPU time.
pub(crate) const REMADE_BEYOND_VOXELS: f32 = 2.0;

/// Where the attraction term reads the target for one node (§4.3).
pub(crate) enum Attraction {
    /// The mean of the target's distance at the node's incident crossings.
    Known(f32),
    /// The target's distance at this world point.
    At(Vec3),
    /// Not read: the step's renormalisation remakes the node.
    Remade,
}

/// Where the target's signed distance at the node's closest skin point X̃ is read (§4.3):
/// the caller evaluates the points of a whole block together.
#[inline]
pub(crate) fn attraction(
    params: &SpeedParams,
    stencil: &Stencil,
    node: &NodeContext,
    crossings: &LocalCrossings,
    crossing_distance: &[f32],
) -> Attraction {
    if params.attraction == AttractionSample::Node {
        return Attraction::At(node.xf.apply(node.ijk.as_vec3()));
    }
    let f = stencil.center();
    let mut sum = 0.0;
    let mut n = 0;
    for axis in 0..3 {
        let e = IVec3::AXES[axis];
        let (lo, hi) = neighbours(stencil, axis);
        if (f < 0.0) != (hi < 0.0) {
            if let Some(v) = crossings.vertex(node.local, axis) {
                sum += crossing_distance[v as usize];
                n += 1;
            }
        }
        if (f < 0.0) != (lo < 0.0) {
            if let Some(v) = crossings.vertex(node.local - e, axis) {
                sum += crossing_distance[v as usize];
                n += 1;
            }
        }
    }
    if n > 0 {
        return Attraction::Known(sum / n as f32);
    }
    if f.abs() >= node.remade_beyond {
        return Attraction::Remade;
    }
    // No incident crossing: the node's projection onto the skin, X − f ∇f/|∇f|². The
    // skin is within the band (w voxels, f = ±1) of any band node: where the gradient
    // flattens at the band's edge (|∇f| < 1/w) the step would overshoot, so it is capped
    // at w|f| there, which is f/max(|∇f|², |∇f|/w) along ∇f.
    let grad = stencil.gradient();
    let g2 = grad.length_squared();
    let scale = if g2 > 1e-12 {
        f / g2.max(g2.sqrt() / node.band_width)
    } else {
        0.0
    };
    let projected = node.ijk.as_vec3() - grad * scale;
    Attraction::At(node.xf.apply(projected))
}

#[inline]
fn neighbours(stencil: &Stencil, axis: usize) -> (f32, f32) {
    match axis {
        0 => (stencil.at(-1, 0, 0), stencil.at(1, 0, 0)),
        1 => (stencil.at(0, -1, 0), stencil.at(0, 1, 0)),
        _ => (stencil.at(0, 0, -1), stencil.at(0, 0, 1)),
    }
}

/// The largest curvature tension acts on, in index units (κΔx): a sphere one voxel in
/// radius. Where the potential is rough (a void closing, a saddle of the start-up
/// density) eq. 4 divides by a vanishing |∇f|³; what the grid cannot resolve is clamped
/// rather than let it set the time step.
pub const MAX_CURVATURE_INDEX: f32 = 2.0;

/// V at a node, world units per second (positive: the skin moves outward there), and
/// its part without tension, which alone sets the CFL bound: tension is parabolic, held
/// by its own bound Δx²/(6β) (§4.8).
#[inline]
pub(crate) fn normal_speed(
    params: &SpeedParams,
    global: &GlobalTerms,
    target_distance: f32,
    curvature_index: f32,
    dx: f32,
) -> (f32, f32) {
    let kappa = curvature_index.clamp(-MAX_CURVATURE_INDEX, MAX_CURVATURE_INDEX) / dx;
    // G − iso = −(signed distance): inside the target the skin inflates.
    let distance = target_distance.clamp(-params.reach, params.reach);
    let advective = params.alpha * (-distance) + global.preservation;
    (advective - params.beta * kappa, advective)
}
