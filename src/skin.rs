//! The active implicit skin (paper §4): a potential on the sparse grid, advanced toward a
//! target in sub-steps (§4.7, §4.8), polygonized after every step.
//!
//! Paper section → module: §3.2/§4.6 [`crate::polygonize`], §3.4/§4.3/§5 [`speed`],
//! §4.1/§4.5 `skin/band.rs`, §4.2 [`crate::grid`], §4.4 `stencil.rs`, §4.7 [`Skin::step`],
//! §4.8 `skin/timestep.rs`.

mod advect;
mod any;
mod band;
mod carry;
mod cover;
mod export;
mod relax;
mod seed;
mod smooth;
pub mod speed;
mod spray;
mod timestep;
pub mod velocity;

use glam::{IVec3, Vec3};
use rayon::prelude::*;

use crate::field::Field;
use crate::flow::{Flow, OnNodes};
use crate::grid::tube::{self, Reach};
use crate::grid::IndexToWorld;
use crate::grid::{
    bits, mask_offsets, node_offset, offset_coords, Halo, Potential, Precision, SparseGrid,
    BLOCK_DIM, BLOCK_NODES,
};
use crate::mesh::Mesh;
use crate::polygonize::{Crossings, Polygonizer};
use crate::stencil::{RowTerms, Stencil};
use crate::target::{Backtracked, Target};

pub use any::AnySkin;
pub use cover::Cover;
pub use speed::{AttractionSample, SpeedParams};
pub use spray::Spray;

/// 0 below 0, 1 above 1, smooth between (the smoothing's weights, the blends of spray
/// and cover).
fn smoothstep(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Largest displacement by the flow in one sub-step, in voxels (the halo is one node).
const ADVECTION_CFL: f32 = 0.9;

/// How the skin is discretised and advanced.
#[derive(Debug, Clone, Copy)]
pub struct SkinParams {
    /// The speed function's gains (§3.4): attraction α, tension β, volume and area.
    pub speed: SpeedParams,
    /// Voxel size Δx, world units.
    pub dx: f32,
    /// Half-width w of the tube in voxels: in the band f ≈ signed distance / (w Δx).
    pub band_width: f32,
    /// Fraction of the stable time step taken (§4.8).
    pub safety: f32,
    /// Upwind renormalisation sweeps per step (0: the paper's unrenormalised potential).
    pub renormalize_sweeps: u32,
    /// How the potential is stored: 32-bit floats, or the paper's 16-bit fixed point
    /// (half the memory, steps of 1/32767 of the band's half-width).
    pub precision: Precision,
    /// Smoothing at the particle scale as each frame settles: voxels² of curvature flow
    /// (`skin/smooth.rs`; 0: none, thin features spared, the volume kept).
    pub smoothing: f32,
}

impl Default for SkinParams {
    fn default() -> Self {
        SkinParams {
            speed: SpeedParams::default(),
            dx: 1.0 / 32.0,
            band_width: 3.0,
            safety: 0.5,
            renormalize_sweeps: 1,
            precision: Precision::F32,
            smoothing: 0.0,
        }
    }
}

/// What a user sets of a skin's parameters, the rest defaulted on the voxel size: what
/// every front end (the commands, Python) makes a skin's [`SkinParams`] from.
#[derive(Debug, Clone, Copy)]
pub struct Physics {
    /// Δx; the input's own when not given.
    pub voxel_size: Option<f32>,
    /// α, the attraction's rate (1/s): how fast the skin closes on its target.
    pub alpha: f32,
    /// β; [`SpeedParams::default_for`] the voxel size and α when not given.
    pub beta: Option<f32>,
    /// The volume constraint's gain (§5.2): 0 leaves the volume free.
    pub volume_gain: f32,
    /// The area constraint's gain (§5.2): 0 leaves the area free.
    pub area_gain: f32,
    /// As [`SkinParams::precision`].
    pub precision: Precision,
    /// How much smoothing, in units of [`SMOOTHING_UNIT`]; none when not given,
    /// [`DEFAULT_PARTICLE_SMOOTHING`] for particles ([`Physics::particle_params`]).
    pub smoothing: Option<f32>,
}

/// What one unit of smoothing does: voxels² of curvature flow a frame on a level set,
/// particle radii² on particles (bumps of wavelength λ decay as exp(−4π²·this/λ²) a
/// frame: those of two particle spacings to 1/3, and their damping adds up from frame to
/// frame). Chosen on a SPlisHSPlasH dam break at cell = r (docs/particles.md, *Smoothing*): the
/// particle-scale bumps of a moving liquid below smoothed splashsurf's at no more time.
pub const SMOOTHING_UNIT: f32 = 8.0 / 3.0;

/// How much smoothing a skin of particles takes when none is given, in units of
/// [`SMOOTHING_UNIT`] (level sets take none: their caches are smooth already).
pub const DEFAULT_PARTICLE_SMOOTHING: f32 = 1.0;

impl Default for Physics {
    fn default() -> Self {
        Physics {
            voxel_size: None,
            alpha: speed::DEFAULT_ALPHA,
            beta: None,
            volume_gain: 0.0,
            area_gain: 0.0,
            precision: Precision::F32,
            smoothing: None,
        }
    }
}

impl Physics {
    /// The parameters on voxels of `voxel_size`, or of `default_dx` when not given;
    /// unchecked ([`SkinParams::check`]).
    pub fn params(&self, default_dx: f32) -> SkinParams {
        let dx = self.voxel_size.unwrap_or(default_dx);
        let defaults = SpeedParams::default_for(dx, self.alpha);
        SkinParams {
            dx,
            speed: SpeedParams {
                alpha: self.alpha,
                beta: self.beta.unwrap_or(defaults.beta),
                volume_gain: self.volume_gain,
                area_gain: self.area_gain,
                ..defaults
            },
            precision: self.precision,
            smoothing: self.smoothing.unwrap_or(0.0) * SMOOTHING_UNIT,
            ..SkinParams::default()
        }
    }

    /// [`Physics::params`] for a skin of particles of `radius` (world units): smoothed
    /// by one unit when no smoothing is given, the unit in radii² so that the particles'
    /// bumps are smoothed alike on every voxel size, and attracted within
    /// [`speed::PARTICLE_REACH_RADII`].
    pub fn particle_params(&self, radius: f32, default_dx: f32) -> SkinParams {
        let dx = self.voxel_size.unwrap_or(default_dx);
        let radii = radius / dx;
        let params = self.params(default_dx);
        SkinParams {
            smoothing: self.smoothing.unwrap_or(DEFAULT_PARTICLE_SMOOTHING)
                * SMOOTHING_UNIT
                * radii
                * radii,
            speed: SpeedParams {
                reach: speed::PARTICLE_REACH_RADII * radius,
                ..params.speed
            },
            ..params
        }
    }
}

impl SkinParams {
    /// Every parameter in its range: rates and gains finite and non-negative (NaN
    /// refused), the voxel size finite and positive, the band at least the 2 voxels the
    /// stencils read, the safety factor in (0, 1], the attraction's reach positive.
    pub fn check(&self) -> Result<(), SkinError> {
        let s = &self.speed;
        let out = |name, value, must| Err(SkinError::Parameter { name, value, must });
        for (name, v) in [
            (Field::Alpha, s.alpha),
            (Field::Beta, s.beta),
            (Field::VolumeGain, s.volume_gain),
            (Field::AreaGain, s.area_gain),
            (Field::Smooth, self.smoothing),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return out(name, v, "a non-negative number");
            }
        }
        if !(self.dx.is_finite() && self.dx > 0.0) {
            return out(Field::VoxelSize, self.dx, "a positive number");
        }
        if !(self.band_width.is_finite() && self.band_width >= 2.0) {
            return out(Field::BandWidth, self.band_width, "at least 2 voxels");
        }
        if !(self.safety > 0.0 && self.safety <= 1.0) {
            return out(Field::Safety, self.safety, "in (0, 1]");
        }
        // Infinite allowed (no bound); the attraction clamps distances by it.
        if s.reach.is_nan() || s.reach <= 0.0 {
            return out(Field::Reach, s.reach, "a positive number or infinity");
        }
        Ok(())
    }
}

/// What one step or one advance did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepStats {
    /// Sub-steps taken (0 for a settle alone).
    pub substeps: u32,
    /// Active nodes of the band.
    pub band_nodes: usize,
    /// Stored 8³ blocks.
    pub blocks: usize,
    /// The mesh's area, world units².
    pub area: f64,
    /// The volume the mesh encloses, world units³.
    pub volume: f64,
    /// V − E + F of the mesh (2 a closed piece without handles; 0 when not counted).
    pub euler_characteristic: i64,
    /// Connected pieces of the mesh (0 when not counted).
    pub components: usize,
    /// Largest |Δφ| / Δx of the last sub-step within w − 1 voxels of the skin (measured
    /// only when [`Skin::track_change`] is on).
    pub max_change_voxels: f32,
    /// Why the advance stopped short, when it would have needed more sub-steps than
    /// [`Skin::limit_substeps`] allows.
    pub stopped: Option<Stopped>,
}

/// An advance that would have needed more sub-steps than allowed, and the bound that
/// forced them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stopped {
    /// The sub-steps the advance would have taken.
    pub needed: f64,
    /// What made them that short.
    pub limit: StepLimit,
}

/// What sets a sub-step's length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepLimit {
    /// The flow's speed (world units a second) and how many voxels it moves in the advance.
    Flow { speed: f32, voxels: f64 },
    /// The attraction's speed, world units a second, at α.
    Attraction { speed: f32, alpha: f32 },
    /// The tension β and the step it allows (seconds).
    Tension { beta: f32, step: f32 },
    /// α (or the area and volume gains), relaxing in 1/α seconds.
    Relaxation { alpha: f32 },
}

impl std::fmt::Display for Stopped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "would need {:.3e} sub-steps: ", self.needed)?;
        match self.limit {
            StepLimit::Flow { speed, voxels } => write!(
                f,
                "the velocity reaches {speed:.3e} world units a second ({voxels:.3e} voxels a frame): check its scale and units"
            ),
            StepLimit::Attraction { speed, alpha } => write!(
                f,
                "the attraction moves the skin {speed:.3e} world units a second (α = {alpha})"
            ),
            StepLimit::Tension { beta, step } => {
                write!(f, "the tension β = {beta} needs steps of {step:.3e} s")
            }
            StepLimit::Relaxation { alpha } => write!(
                f,
                "α = {alpha} (or the area and volume gains) relaxes the skin in {:.3e} s",
                1.0 / alpha
            ),
        }
    }
}

/// Most sub-steps a frame of the frame loop may take (real runs take 1–40, 75 with a
/// Mantaflow `phi` in voxels read as world units): beyond, it stops and says which bound
/// forced them — a velocity or α out of all proportion, a frame rate of almost nothing,
/// particles of 10 µm moving a metre a second — instead of running until killed (a
/// thousand sub-steps of a band of 600 k nodes are two minutes; 10 000 were allowed).
pub const MAX_SUBSTEPS: u32 = 1_000;

/// What a block within reach of the start's surface costs while a skin runs: its
/// potential, its rate, its advection's and renormalisation's scratch, its share of the
/// mesh and of the crossings. Measured with `morph` on spheres 125 and 500 voxels in
/// radius (7.5 k and 124 k such blocks, 0.2 and 2.5 GB at their peak): 40–55 bytes a
/// node, here 48.
const BAND_BLOCK_BYTES: f64 = (48 * BLOCK_NODES) as f64;

/// What listing the blocks around `target` costs (16 bytes each, with their distances).
fn fits_budget(target: &dyn Target, dx: f32, w: f32, budget: u64) -> Result<(), SkinError> {
    let xf = IndexToWorld {
        origin: Vec3::ZERO,
        dx,
    };
    check_budget(seed::blocks_listed(target, xf, w) * 16.0, dx, budget)
}

fn check_budget(needed: f64, dx: f32, budget: u64) -> Result<(), SkinError> {
    if needed <= budget as f64 {
        return Ok(());
    }
    Err(SkinError::OverBudget {
        needed: needed.min(u64::MAX as f64) as u64,
        budget,
        dx,
    })
}

/// A skin stored with potential type `P`.
pub struct Skin<P> {
    grid: SparseGrid<P>,
    params: SkinParams,
    xf: IndexToWorld,
    time: f64,
    mesh: Mesh,
    crossings: Crossings,
    /// Target distance at each crossing point, one evaluation each (§4.3.2).
    crossing_distance: Vec<f32>,
    polygonizer: Polygonizer,
    /// ∂f/∂t of each node, then scratch for renormalisation.
    rates: Vec<[f32; BLOCK_NODES]>,
    advect_scratch: advect::Scratch,
    /// Area and volume of the last mesh, measured once per polygonization.
    area: f64,
    volume: f64,
    rest_area: f64,
    rest_volume: f64,
    last_change: f32,
    track_change: bool,
    /// At most this many sub-steps an advance ([`Skin::limit_substeps`]).
    max_substeps: Option<u32>,
    /// Whether an advance's stats count the mesh's χ and components
    /// ([`Skin::count_topology`]).
    count_topology: bool,
}

impl<P: Potential> Skin<P> {
    /// [`Skin::new`] with its parameters checked first ([`SkinParams::check`]).
    pub fn try_new(start: &dyn Target, params: SkinParams) -> Result<Self, SkinError> {
        params.check()?;
        Self::build(start, params, crate::budget::bytes())
    }

    /// A skin whose zero set is the surface of `start`, sampled on voxels of `params.dx`
    /// (parameters as given: [`Skin::try_new`] checks them).
    pub fn new(start: &dyn Target, params: SkinParams) -> Self {
        Self::build(start, params, u64::MAX).expect("no memory budget to exceed")
    }

    /// [`Skin::new`] within a memory budget of `budget` bytes.
    fn build(start: &dyn Target, params: SkinParams, budget: u64) -> Result<Self, SkinError> {
        let dx = params.dx;
        let w = params.band_width;
        let xf = IndexToWorld {
            origin: Vec3::ZERO,
            dx,
        };
        let reach = seed::block_reach(w, dx);
        fits_budget(start, dx, w, budget)?;
        let classified = seed::classify_blocks(start, xf, w);
        let band = classified.iter().filter(|(_, d)| d.abs() <= reach).count();
        check_budget(band as f64 * BAND_BLOCK_BYTES, dx, budget)?;
        let mut grid = SparseGrid::new();
        for (c, d) in classified {
            if d > reach {
                continue;
            } else if d < -reach {
                grid.set_tile(c, true);
            } else {
                grid.touch(c);
            }
        }
        band::start_consistently(&mut grid);
        let value = |ijk: IVec3| start.distance(xf.apply(ijk.as_vec3())) / (w * dx);
        band::fill(&mut grid, value);
        // A start target steeper than a distance can put the skin between blocks it
        // classified on either side: store them until every crossed cell is (a few rounds
        // at most; none for a distance).
        for _ in 0..4 {
            let missing = band::unstored_crossed(&grid);
            if missing.is_empty() {
                break;
            }
            for c in missing {
                grid.touch(c);
            }
            band::fill(&mut grid, value);
        }
        let mut scratch = Vec::new();
        band::clamp_at_crossings(&mut grid, w, &mut scratch);
        crate::grid::tube::upkeep(&mut grid);
        grid.shrink_to_fit();
        let mut skin = Skin {
            grid,
            params,
            xf,
            time: 0.0,
            mesh: Mesh::default(),
            crossings: Crossings::default(),
            crossing_distance: Vec::new(),
            polygonizer: Polygonizer::default(),
            rates: Vec::new(),
            advect_scratch: advect::Scratch::default(),
            area: 0.0,
            volume: 0.0,
            rest_area: 0.0,
            rest_volume: 0.0,
            last_change: 0.0,
            track_change: false,
            max_substeps: None,
            count_topology: true,
        };
        for _ in 0..3 {
            band::renormalize(&mut skin.grid, w, 0.0, &mut skin.rates);
            crate::grid::tube::upkeep(&mut skin.grid);
        }
        skin.polygonize();
        skin.rest_area = skin.area;
        skin.rest_volume = skin.volume;
        Ok(skin)
    }

    /// Whether seeding the skin from `target` ([`Skin::seed`], every frame) fits the
    /// memory budget: a target far larger than the voxels (an analytic shape kilometres
    /// across at millimetre voxels) is refused before its blocks are listed.
    pub fn check_target(&self, target: &dyn Target) -> Result<(), SkinError> {
        let (dx, w) = (self.params.dx, self.params.band_width);
        fits_budget(target, dx, w, crate::budget::bytes())
    }

    pub fn params(&self) -> &SkinParams {
        &self.params
    }

    pub fn set_speed(&mut self, speed: SpeedParams) {
        self.params.speed = speed;
    }

    /// The area and volume the preservation terms (§5) hold the skin to.
    pub fn set_rest_measures(&mut self, area: f64, volume: f64) {
        self.rest_area = area;
        self.rest_volume = volume;
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn grid(&self) -> &SparseGrid<P> {
        &self.grid
    }

    /// The mesh of the last polygonization.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    pub fn stats(&self) -> StepStats {
        self.stats_with(true)
    }

    /// [`Skin::stats`], the mesh's χ and components (a walk over the whole mesh) left at
    /// 0 unless `topology`.
    pub fn stats_with(&self, topology: bool) -> StepStats {
        StepStats {
            substeps: 0,
            band_nodes: self.grid.active_node_count(),
            blocks: self.grid.block_count(),
            area: self.area,
            volume: self.volume,
            euler_characteristic: if topology {
                self.mesh.euler_characteristic()
            } else {
                0
            },
            components: if topology { self.mesh.components() } else { 0 },
            max_change_voxels: self.last_change,
            stopped: None,
        }
    }

    /// Advances the skin by `duration` seconds toward `target`, in stable sub-steps that
    /// land exactly on the end time.
    pub fn advance(&mut self, target: &dyn Target, duration: f64) -> StepStats {
        self.advance_in_flow(target, None, duration)
    }

    /// [`Skin::advance`] with the material's velocity known (§7): the skin is carried by
    /// `flow` (`∂φ/∂t + u·∇φ = −V|∇φ|`), and attracted at each sub-step's own time to
    /// `target` — the surface at the end of `duration` — carried back along the flow for
    /// the time still to go, so that α corrects the shape, not the motion.
    pub fn advance_in_flow(
        &mut self,
        target: &dyn Target,
        flow: Option<&dyn Flow>,
        duration: f64,
    ) -> StepStats {
        let mut remaining = duration;
        let mut substeps = 0;
        if flow.is_some() {
            // The first sub-step's advection reaches as far as the others'.
            tube::upkeep_reaching(&mut self.grid, Reach::Cube);
        }
        let mut on_nodes = flow
            .filter(|f| f.costly())
            .map(|f| OnNodes::new(f, self.xf));
        while remaining > 0.0 {
            let flow = match &mut on_nodes {
                Some(nodes) => {
                    nodes.cover(&self.grid);
                    Some(&*nodes as &dyn Flow)
                }
                None => flow,
            };
            let (v_max, u_max) = match flow {
                Some(flow) => {
                    let ahead = Backtracked {
                        target,
                        flow,
                        ahead: remaining as f32,
                    };
                    (self.compute_rates(&ahead), self.sample_flow(flow))
                }
                None => (self.compute_rates(target), 0.0),
            };
            // Semi-Lagrangian advection is stable at any step; the flow's own bound only
            // keeps departure points within the one-node halo. Fewer, longer steps also
            // diffuse less.
            let carried = if u_max > 0.0 {
                ADVECTION_CFL * self.params.dx / u_max
            } else {
                f32::INFINITY
            };
            let stable = self.dt_bound(v_max).min(carried);
            if let Some(most) = self.max_substeps {
                let needed = f64::from(substeps) + (remaining / f64::from(stable)).ceil();
                if needed.is_nan() || needed > f64::from(most) {
                    let limit = self.step_limit(v_max, (u_max, carried), duration);
                    return StepStats {
                        substeps,
                        stopped: Some(Stopped { needed, limit }),
                        ..self.stats_with(self.count_topology)
                    };
                }
            }
            let dt = timestep::next_substep(remaining, stable);
            self.apply_rates(dt as f32, flow);
            self.time += dt;
            remaining -= dt;
            substeps += 1;
        }
        StepStats {
            substeps,
            ..self.stats_with(self.count_topology)
        }
    }

    /// The bound that sets the sub-step: the flow's speed (`u_max`, the step it allows
    /// `carried`), the attraction's (`v_max`), the tension β, or a relaxation rate.
    fn step_limit(&self, v_max: f32, (u_max, carried): (f32, f32), duration: f64) -> StepLimit {
        let dx = self.params.dx;
        let speed = &self.params.speed;
        if carried <= self.dt_bound(v_max) {
            return StepLimit::Flow {
                speed: u_max,
                voxels: f64::from(u_max / dx) * duration,
            };
        }
        let hyperbolic = dx / v_max;
        let parabolic = dx * dx / (6.0 * speed.beta);
        if v_max > 0.0 && hyperbolic <= parabolic && hyperbolic <= 1.0 / speed.alpha {
            StepLimit::Attraction {
                speed: v_max,
                alpha: speed.alpha,
            }
        } else if speed.beta > 0.0 && parabolic <= 1.0 / speed.alpha {
            StepLimit::Tension {
                beta: speed.beta,
                step: parabolic,
            }
        } else {
            StepLimit::Relaxation { alpha: speed.alpha }
        }
    }

    /// The largest speed of `flow` at band nodes, world units per second.
    fn sample_flow(&self, flow: &dyn Flow) -> f32 {
        let xf = self.xf;
        self.grid
            .blocks()
            .par_iter()
            .map(|block| {
                let base = block.coord * BLOCK_DIM;
                block
                    .active_offsets()
                    .filter(|&offset| block.values[offset].to_f32().abs() < 1.0)
                    .map(|offset| {
                        let x = xf.apply((base + offset_coords(offset)).as_vec3());
                        flow.velocity(x).length()
                    })
                    .fold(0.0f32, f32::max)
            })
            .reduce(|| 0.0, f32::max)
    }

    /// One time step of §4.7 with a given `dt`: speeds from a consistent potential, then
    /// update, clamp, retire and wake, then polygonize for the next step.
    pub fn step(&mut self, target: &dyn Target, dt: f32) {
        self.compute_rates(target);
        self.apply_rates(dt, None);
        self.time += f64::from(dt);
    }

    /// The largest stable time step for the current state against `target`.
    pub fn stable_dt(&mut self, target: &dyn Target) -> f32 {
        let v_max = self.compute_rates(target);
        self.dt_bound(v_max)
    }

    /// §4.8's bound, with the relaxation rates of the attraction (α), the volume term
    /// (γ_V·A/V0: a uniform speed changes the volume at A per unit) and the area term
    /// (γ_A·κ̄ with κ̄ ≈ 2/r of the sphere of the same area).
    fn dt_bound(&self, v_max: f32) -> f32 {
        let speed = &self.params.speed;
        let area = self.area.max(1e-12);
        let volume_rate = if self.rest_volume > 0.0 {
            speed.volume_gain * (area / self.rest_volume) as f32
        } else {
            0.0
        };
        let mean_curvature = 2.0 / (area / (4.0 * std::f64::consts::PI)).sqrt() as f32;
        let relaxation = speed
            .alpha
            .max(volume_rate)
            .max(speed.area_gain * mean_curvature);
        timestep::stable_dt(
            self.params.dx,
            v_max,
            speed.beta,
            relaxation,
            self.params.safety,
        )
    }

    /// Pass 1 (read-only): ∂f/∂t at every active node. Returns the largest |V| without
    /// tension among nodes in the band, for the CFL bound.
    fn compute_rates(&mut self, target: &dyn Target) -> f32 {
        // G at each crossing point of the last mesh: one target evaluation each.
        let positions = self.crossings.points();
        self.crossing_distance.clear();
        self.crossing_distance
            .par_extend(positions.par_iter().map(|&p| target.distance(p)));

        let global = speed::GlobalTerms::new(
            &self.params.speed,
            (self.area, self.rest_area),
            (self.volume, self.rest_volume),
        );
        let grid = &self.grid;
        let params = &self.params;
        let xf = self.xf;
        let crossings = &self.crossings;
        let crossing_distance = &self.crossing_distance;
        let remade_beyond = match params.renormalize_sweeps {
            0 => f32::INFINITY,
            _ => speed::REMADE_BEYOND_VOXELS / params.band_width,
        };
        self.rates.resize(grid.block_count(), [0.0; BLOCK_NODES]);
        self.rates
            .par_iter_mut()
            .zip(grid.blocks().par_iter())
            .map_init(Box::<RatesScratch>::default, |scratch, (rates, block)| {
                let RatesScratch {
                    halo,
                    distance,
                    queries,
                } = &mut **scratch;
                let around = grid.neighbourhood_of(block);
                halo.fill(grid, &around);
                let crossings = crossings.around(&around);
                let base = block.coord * BLOCK_DIM;
                // The target's distance for every node first, the points to evaluate
                // gathered and then evaluated together: the projections' arithmetic of
                // many nodes overlaps, instead of waiting on each node's call.
                queries.clear();
                for offset in block.active_offsets() {
                    let l = offset_coords(offset);
                    let node = speed::NodeContext {
                        ijk: base + l,
                        local: l,
                        xf,
                        band_width: params.band_width,
                        remade_beyond,
                    };
                    let stencil = Stencil::from_halo(halo, l.x, l.y, l.z);
                    match speed::attraction(
                        &params.speed,
                        &stencil,
                        &node,
                        &crossings,
                        crossing_distance,
                    ) {
                        speed::Attraction::Known(d) => distance[offset] = d,
                        speed::Attraction::At(p) => queries.push((offset, p)),
                        // Tension and preservation alone move it (a guess the sweep replaces).
                        speed::Attraction::Remade => distance[offset] = 0.0,
                    }
                }
                for &(offset, p) in queries.iter() {
                    distance[offset] = target.distance(p);
                }
                let mut v_max = 0.0f32;
                for (x, y, row) in block.active_rows() {
                    let terms = RowTerms::of(halo, x, y);
                    for z in bits(row) {
                        let offset = node_offset(x, y, z);
                        let (v, advective) = speed::normal_speed(
                            &params.speed,
                            &global,
                            distance[offset],
                            terms.curvature[z as usize],
                            params.dx,
                        );
                        // ∂φ/∂t = −V|∇φ| with φ = f·wΔx and ∇ in index units, upwind.
                        let norm = if v > 0.0 {
                            terms.outward[z as usize]
                        } else {
                            terms.inward[z as usize]
                        };
                        rates[offset] = -v * norm / params.dx;
                        if halo.at(x, y, z).abs() < 1.0 {
                            v_max = v_max.max(advective.abs());
                        }
                    }
                }
                v_max
            })
            .reduce(|| 0.0, f32::max)
    }

    /// Pass 2: f += dt ∂f/∂t, clamped; band upkeep; renormalisation; polygonization.
    fn apply_rates(&mut self, dt: f32, flow: Option<&dyn Flow>) {
        let w = self.params.band_width;
        let before = self.track_change.then(|| self.grid.clone());
        // The blocks the band reaches, read as each block is written (in cache), unless
        // the advection moves the values again.
        let reached_now = flow.is_none();
        let mut wake: Vec<(IVec3, u32)> = self
            .grid
            .blocks_mut()
            .par_iter_mut()
            .zip(self.rates.par_iter())
            .map(|(block, rates)| {
                for offset in mask_offsets(block.active) {
                    let f = block.values[offset].to_f32();
                    block.values[offset] = P::from_f32((f + dt * rates[offset]).clamp(-1.0, 1.0));
                }
                let reached = if reached_now {
                    tube::blocks_reached(&block.values)
                } else {
                    0
                };
                (block.coord, reached)
            })
            .collect();
        // In a flow the nodes within 1.5 voxels of the skin, which the advection's cubic
        // reads, keep their carried values: the first-order Eikonal sweep would bias them
        // every step (a sphere of 8 voxels lost 4 % of its volume a turn; kept within 1, 1.5,
        // 2 and 2.5 voxels: −3.0, +0.1, +0.6, +1.0 %).
        let (keep, reach) = if let Some(flow) = flow {
            advect::maccormack(&mut self.grid, flow, self.xf, dt, &mut self.advect_scratch);
            wake = tube::wake_list(&self.grid);
            (1.5 / w, Reach::Cube)
        } else {
            (0.0, Reach::Faces)
        };
        // The first renormalisation sweep runs with the upkeep, from the same halos.
        let sweeps = self.params.renormalize_sweeps;
        let sweep = (sweeps > 0).then(|| tube::Sweep {
            update: band::renormalizing(w, keep),
            scratch: &mut self.rates,
        });
        tube::upkeep_from(&mut self.grid, reach, &wake, sweep);
        for _ in 1..sweeps {
            band::renormalize(&mut self.grid, w, keep, &mut self.rates);
        }
        if let Some(before) = before {
            self.last_change = max_change(&before, &self.grid, w) * w;
        }
        self.polygonize();
    }

    /// Stops each advance that would need more than `most` sub-steps before taking them
    /// (its [`StepStats::stopped`] says why); `None`: no limit.
    pub fn limit_substeps(&mut self, most: Option<u32>) {
        self.max_substeps = most;
    }

    /// Whether the stats an advance returns count the mesh's χ and components (the
    /// default): two walks over the whole mesh on one thread, which a caller taking the
    /// topology elsewhere (the frame loop, when it writes) need not pay each frame.
    pub fn count_topology(&mut self, on: bool) {
        self.count_topology = on;
    }

    /// Record the largest |Δφ| of each step in [`StepStats::max_change_voxels`] (costs a
    /// copy of the grid per step; for tests and diagnostics).
    pub fn track_change(&mut self, on: bool) {
        self.track_change = on;
    }

    fn polygonize(&mut self) {
        self.polygonizer
            .run(&self.grid, self.xf, &mut self.mesh, &mut self.crossings);
        (self.area, self.volume) = self.mesh.area_and_volume();
    }

    /// Sets the clock (seconds), e.g. after [`Skin::restore`].
    pub fn set_time(&mut self, time: f64) {
        self.time = time;
    }

    /// Bytes held by the potential's grid.
    pub fn memory_bytes(&self) -> usize {
        self.grid.memory_bytes()
    }
}

/// Largest |f_after − f_before| over nodes within w − 1 voxels of the skin in either
/// grid: those its position, normals and curvature are read from. (Nodes at the tube's
/// outer edge flicker against the clamp at ±1 without touching the skin.)
fn max_change<P: Potential>(before: &SparseGrid<P>, after: &SparseGrid<P>, band_width: f32) -> f32 {
    let near = (band_width - 1.0) / band_width;
    let one_way = |a: &SparseGrid<P>, b: &SparseGrid<P>| {
        a.blocks()
            .par_iter()
            .map(|block| {
                let base = block.coord * BLOCK_DIM;
                let mut m = 0.0f32;
                for (offset, v) in block.values.iter().enumerate() {
                    let f = v.to_f32();
                    let g = b.value(base + offset_coords(offset));
                    if f.abs() < near || g.abs() < near {
                        m = m.max((f - g).abs());
                    }
                }
                m
            })
            .reduce(|| 0.0, f32::max)
    };
    one_way(before, after).max(one_way(after, before))
}

/// A thread's buffers for the speed pass, one block at a time.
struct RatesScratch {
    halo: Halo,
    /// The target's distance at each node's attraction point.
    distance: [f32; BLOCK_NODES],
    /// Nodes whose attraction point is still to evaluate, with the point.
    queries: Vec<(usize, Vec3)>,
}

impl Default for RatesScratch {
    fn default() -> Self {
        RatesScratch {
            halo: Halo::default(),
            distance: [0.0; BLOCK_NODES],
            queries: Vec::with_capacity(BLOCK_NODES),
        }
    }
}

/// A state the skin cannot take.
#[derive(Debug, thiserror::Error)]
pub enum SkinError {
    #[error("cannot restore the skin: {0}")]
    Incompatible(String),
    /// The skin's blocks around a target would take more than the memory budget.
    #[error(
        "the skin's band would take {} at voxels of {dx}, over the memory budget of {}: give a larger voxel size (or {})",
        crate::budget::size(*needed),
        crate::budget::size(*budget),
        Field::MaxMemory
    )]
    OverBudget { needed: u64, budget: u64, dx: f32 },
    /// A parameter out of its range ([`SkinParams::check`]).
    #[error("{name} must be {must}, got {value}")]
    Parameter {
        name: Field,
        value: f32,
        must: &'static str,
    },
}
