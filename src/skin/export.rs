//! The skin as a VDB level set and back: export (re-distanced next to the skin), restore,
//! and the canonical state every frame ends in.

use glam::IVec3;

use super::{band, Cover, Skin, SkinError, Spray};
use crate::grid::{Potential, BLOCK_DIM, BLOCK_NODES};
use crate::target::Target;
use crate::volume::{GridClass, GridData, Tile, Transform, MASK_WORDS};

/// The volume's offset (voxels) from which the settle fits the band to the skin again:
/// the double dam break's settles offset it 0.07 voxel at most (that re-fit and its mesh
/// took about 4 % of its CPU).
const REFIT_OFFSET: f32 = 0.25;

impl<P: Potential> Skin<P> {
    /// The skin as a narrow-band level set: signed distance φ = f·wΔx in world units,
    /// active where |φ| < wΔx, background wΔx, inside tiles at −wΔx (grid `surface`).
    /// The nodes next to the skin are re-distanced from its mesh first (the triangles of
    /// the cells around each, cut again from the grid): the solver keeps their values
    /// (they define the skin), which are not a distance in a thin neck, where
    /// checkLevelSet would flag them.
    pub fn to_level_set(&self) -> GridData {
        self.level_set(false)
    }

    /// [`Skin::to_level_set`], every node next to the skin re-distanced when `exact`
    /// (none kept for its slope looking right).
    fn level_set(&self, exact: bool) -> GridData {
        let dx = self.params.dx;
        let w = self.params.band_width;
        let background = self.background();
        let mut grid = self.grid.clone();
        match exact {
            true => band::redistance_within(&mut grid, w, 0.0, &mut Vec::new()),
            false => band::redistance(&mut grid, w, &mut Vec::new()),
        }
        let origin = self.xf.origin.as_dvec3().to_array();
        let transform = Transform::uniform(f64::from(dx), origin);
        let mut data = GridData::empty("surface", GridClass::LevelSet, background, transform);
        let mut values = [0.0f32; BLOCK_NODES];
        for block in grid.blocks() {
            let mut mask = [0u64; MASK_WORDS];
            for (offset, (out, v)) in values.iter_mut().zip(&block.values).enumerate() {
                let f = v.to_f32();
                *out = if f.abs() >= 1.0 {
                    f.signum() * background
                } else {
                    f * background
                };
                if f.abs() < 1.0 {
                    mask[offset >> 6] |= 1 << (offset & 63);
                }
            }
            data.push_leaf((block.coord * BLOCK_DIM).to_array(), &values, mask);
        }
        let mut inside: Vec<IVec3> = grid.inside_tiles().iter().copied().collect();
        inside.sort_unstable_by_key(|c| c.to_array());
        data.tiles = inside
            .into_iter()
            .map(|c| Tile {
                origin: (c * BLOCK_DIM).to_array(),
                dim: BLOCK_DIM as u32,
                value: -background,
                active: false,
            })
            .collect();
        data
    }

    /// Replaces the potential by a level set as [`Skin::to_level_set`] writes it (same
    /// voxel size, origin at world zero), then rebuilds the tube and the mesh. `--resume`
    /// reads the last frame back this way; an uninterrupted run restores each frame it
    /// writes too, so that both runs go on from the same state, bit for bit.
    pub fn restore(&mut self, data: &GridData) -> Result<(), SkinError> {
        let dx = f64::from(self.params.dx);
        let found = data.transform.voxel_size();
        let origin = data.transform.index_to_world([0.0; 3]);
        if !data.uniform_linear || (found - dx).abs() > 1e-9 * dx || origin != [0.0; 3] {
            return Err(SkinError::Incompatible(format!(
                "grid '{}' has voxel size {found} and origin {origin:?}, the skin {dx} at the world origin",
                data.name
            )));
        }
        let scale = self.background();
        self.grid.import(data, |phi| phi / scale);
        crate::grid::tube::upkeep(&mut self.grid);
        self.polygonize();
        if self.params.smoothing > 0.0 {
            self.relax_mesh();
        }
        Ok(())
    }

    /// Ends a frame: the skin takes the state its VDB level set holds
    /// ([`Skin::to_level_set`], then [`Skin::restore`]), which is returned for writing.
    /// Every frame ends so, written or not, so the skin never depends on its outputs.
    pub fn settle(&mut self) -> GridData {
        self.settle_holding(None, None, None)
    }

    /// [`Skin::settle`], the skin first smoothed ([`SkinParams::smoothing`], staying near
    /// the frame's target `near` when given) and held to `volume` (world units³; the
    /// volume before the smoothing when not given) by the uniform normal offset that
    /// gives it back (§5.2's constraint met at once), meshed once, by the restore: for
    /// inputs that conserve their volume, such as an incompressible liquid's particles,
    /// whose density's iso-surface does not. Given `particles`' target, spray and cover:
    /// around the spray the skin takes its target's surface ([`Spray`]) before the
    /// smoothing, which then spares the drops as small pieces, and again after the
    /// offset, which could close the gap between a drop and the liquid it left; and,
    /// smoothed, it first takes the target's surface around the particles it leaves
    /// outside, where that lies farther out ([`Cover`]).
    pub fn settle_holding(
        &mut self,
        volume: Option<f64>,
        near: Option<&dyn Target>,
        particles: Option<(&dyn Target, &Spray, &Cover)>,
    ) -> GridData {
        let smoothing = self.params.smoothing;
        let take = |skin: &mut Self| particles.is_some_and(|(t, s, _)| skin.take_target_near(t, s));
        let took = take(self);
        let covered =
            smoothing > 0.0 && particles.is_some_and(|(t, _, c)| self.cover_particles(t, c));
        if took || covered {
            self.polygonize();
        }
        let volume = match smoothing > 0.0 {
            true => {
                let unsmoothed = self.volume;
                self.smooth(smoothing, near);
                volume.or(Some(unsmoothed))
            }
            false => volume,
        };
        let mut offset = 0.0;
        if let Some(volume) = volume {
            // The offset is measured to first order; a smoothed skin's is larger (the
            // flow took from its convex parts), so it is measured again once.
            offset = self.shift_to_volume(volume);
            if offset != 0.0 && smoothing > 0.0 {
                self.polygonize();
                offset += self.shift_to_volume(volume);
            }
        }
        if smoothing > 0.0 {
            // The smoothing left the band a distance (`Skin::smooth`); an offset of a
            // voxel or more does not (checkLevelSet would flag it). A smaller offset
            // keeps the slopes and moves the band's edge as much: the export's exact
            // re-distancing is enough, and the mesh between the two offsets (the second
            // a thousandth of a voxel) finds the crumbs.
            if offset.abs() >= REFIT_OFFSET {
                self.refit_band();
                self.polygonize();
            }
            // The flow or the offset may have pinched a tip off.
            self.drop_crumbs();
        }
        // Meshed by the restore.
        take(self);
        // Every node next to the skin re-distanced where it was smoothed: keeping those
        // whose slope looks right leaves thin sheets out of checkLevelSet's range
        // (tests/cli_demo.rs).
        let level_set = self.level_set(smoothing > 0.0);
        self.restore(&level_set)
            .expect("a skin's own level set has its voxel size and origin");
        level_set
    }

    /// The exported level set's background, w·Δx: the world distance of f = 1.
    fn background(&self) -> f32 {
        crate::volume::narrow_band_background(self.params.band_width, self.params.dx)
    }
}
