//! A velocity grid as a flow: trilinear sampling of each component where it lives
//! (collocated, or on the voxel faces of a staggered MAC grid), extended past the grid's
//! active voxels so that a skin just outside the liquid is carried too.

use glam::{DMat4, DVec3, IVec3, Vec3};
use hashbrown::{HashMap, HashSet};

use super::Flow;
use crate::volume::{VectorGrid, LEAF_VOXELS};

/// Layers of voxels added around the active ones, each taking the mean of its active face
/// neighbours: the skin's band reaches three voxels past the surface.
pub const EXTENSION_LAYERS: u32 = 3;

/// Layers added at most for the motion over a frame ([`GridFlow::new`]): a skin carried
/// further than that in a frame is left to the attraction and the seeding.
pub const MAX_MOTION_LAYERS: u32 = 61;

/// Why a velocity grid cannot be used as a flow.
#[derive(Debug, thiserror::Error)]
pub enum GridFlowError {
    #[error("grid '{name}' has an active tile of {dim}³ voxels; densify it first")]
    WideTile { name: String, dim: u32 },
    #[error(
        "grid '{name}' has {count} voxel{} whose velocity is NaN or infinite{}",
        if *count == 1 { "" } else { "s" },
        if *scaled { " after the scale" } else { "" }
    )]
    NotFinite {
        name: String,
        count: usize,
        scaled: bool,
    },
    #[error("grid '{0}' has a singular transform")]
    SingularTransform(String),
}

/// A velocity grid, world units per second after `scale`.
pub struct GridFlow {
    /// The voxels in blocks of 8³: a sample's eight corners are mostly one lookup.
    blocks: HashMap<IVec3, Box<VelocityBlock>>,
    to_index: DMat4,
    staggered: bool,
}

/// 8³ voxels, OpenVDB's order, and which of them hold a velocity.
struct VelocityBlock {
    values: [Vec3; LEAF_VOXELS],
    present: [u64; LEAF_VOXELS / 64],
}

#[inline]
fn local_offset(l: IVec3) -> usize {
    (l.x * 64 + l.y * 8 + l.z) as usize
}

impl VelocityBlock {
    #[inline]
    fn get(&self, o: usize) -> Option<Vec3> {
        (self.present[o >> 6] >> (o & 63) & 1 == 1).then(|| self.values[o])
    }
}

impl GridFlow {
    /// The grid's active voxels and tiles times `scale`, extended by
    /// [`EXTENSION_LAYERS`] and by as many more as its fastest voxel travels in
    /// `duration` seconds (at most [`MAX_MOTION_LAYERS`]): a frame's carry traces each
    /// node of the skin's new band back from where the liquid went, beyond the voxels a
    /// solver stores (a FLIP cache's velocity stops at its liquid). Tiles wider than 64
    /// voxels are refused (a uniform velocity over a region that size is better given as
    /// a rigid motion), and so are velocities that are NaN or infinite.
    pub fn new(grid: &VectorGrid, scale: f32, duration: f64) -> Result<Self, GridFlowError> {
        let mut voxels = HashMap::new();
        for (ijk, v) in grid.active_voxels() {
            voxels.insert(IVec3::from_array(ijk), Vec3::from(v) * scale);
        }
        for tile in &grid.tiles {
            if tile.dim > 64 {
                return Err(GridFlowError::WideTile {
                    name: grid.name.clone(),
                    dim: tile.dim,
                });
            }
            let lo = IVec3::from_array(tile.origin);
            let d = tile.dim as i32;
            for x in 0..d {
                for y in 0..d {
                    for z in 0..d {
                        voxels.insert(lo + IVec3::new(x, y, z), Vec3::from(tile.value) * scale);
                    }
                }
            }
        }
        // A solver's blow-up (or a scale too large for f32) would poison every sample
        // near it.
        let bad = voxels.values().filter(|v| !v.is_finite()).count();
        if bad > 0 {
            return Err(GridFlowError::NotFinite {
                name: grid.name.clone(),
                count: bad,
                scaled: scale != 1.0,
            });
        }
        let fastest = voxels.values().fold(0.0f32, |m, v| m.max(v.length()));
        let voxel = grid.transform.voxel_size();
        let travelled = (f64::from(fastest) * duration / voxel).ceil();
        let motion = if travelled.is_finite() {
            travelled.clamp(0.0, f64::from(MAX_MOTION_LAYERS)) as u32
        } else {
            MAX_MOTION_LAYERS
        };
        extend(&mut voxels, EXTENSION_LAYERS + motion);
        // OpenVDB's row-vector matrix read column-major is the column-vector map.
        let to_index = DMat4::from_cols_array(&grid.transform.matrix).inverse();
        if !to_index.is_finite() {
            return Err(GridFlowError::SingularTransform(grid.name.clone()));
        }
        let mut blocks: HashMap<IVec3, Box<VelocityBlock>> = HashMap::new();
        for (v, u) in voxels {
            let block = blocks.entry(v >> 3).or_insert_with(|| {
                Box::new(VelocityBlock {
                    values: [Vec3::ZERO; LEAF_VOXELS],
                    present: [0; LEAF_VOXELS / 64],
                })
            });
            let o = local_offset(v & 7);
            block.values[o] = u;
            block.present[o >> 6] |= 1 << (o & 63);
        }
        Ok(GridFlow {
            blocks,
            to_index,
            staggered: grid.staggered,
        })
    }

    /// Trilinear interpolation of component `c` at index point `q`, over the voxels that
    /// hold a value (weights renormalised); zero where none does.
    fn component(&self, q: DVec3, c: usize) -> f32 {
        let base = q.floor();
        let t = (q - base).as_vec3();
        let b = base.as_ivec3();
        let (mut sum, mut weight) = (0.0f32, 0.0f32);
        let local = b & 7;
        // All eight corners in one block unless the cell straddles a block face.
        let one = (local.cmplt(IVec3::splat(7)).all())
            .then(|| self.blocks.get(&(b >> 3)))
            .flatten();
        for corner in 0..8 {
            let d = IVec3::new(corner & 1, corner >> 1 & 1, corner >> 2 & 1);
            let value = match one {
                Some(block) => block.get(local_offset(local + d)),
                None => {
                    let v = b + d;
                    self.blocks
                        .get(&(v >> 3))
                        .and_then(|block| block.get(local_offset(v & 7)))
                }
            };
            if let Some(v) = value {
                let w: f32 = [0, 1, 2]
                    .map(|a| if d[a] == 1 { t[a] } else { 1.0 - t[a] })
                    .iter()
                    .product();
                sum += w * v[c];
                weight += w;
            }
        }
        if weight > 1e-6 {
            sum / weight
        } else {
            0.0
        }
    }
}

impl Flow for GridFlow {
    fn costly(&self) -> bool {
        true
    }

    fn velocity(&self, p: Vec3) -> Vec3 {
        let q = self.to_index.transform_point3(p.as_dvec3());
        Vec3::from_array(std::array::from_fn(|c| {
            // A staggered component c sits at v − ½ e_c: sample at q + ½ e_c.
            let mut at = q;
            if self.staggered {
                at[c] += 0.5;
            }
            self.component(at, c)
        }))
    }
}

/// Adds `layers` rings of voxels around those present, each the mean of its present face
/// neighbours (a constant extension of the velocity along the normal, roughly). Each mean
/// sums the faces in a fixed order, so the result does not depend on the map's order (a
/// resumed run must repeat an uninterrupted one bit for bit).
fn extend(voxels: &mut HashMap<IVec3, Vec3>, layers: u32) {
    use crate::grid::FACES;
    // Each ring grows from the one before: a deep extension costs its own voxels only.
    let mut last: Vec<IVec3> = voxels.keys().copied().collect();
    for _ in 0..layers {
        let ring: HashSet<IVec3> = last
            .iter()
            .flat_map(|&v| FACES.map(|f| v + f))
            .filter(|n| !voxels.contains_key(n))
            .collect();
        if ring.is_empty() {
            return;
        }
        let added: Vec<(IVec3, Vec3)> = ring
            .into_iter()
            .map(|n| {
                let (sum, count) = FACES
                    .iter()
                    .filter_map(|&f| voxels.get(&(n + f)))
                    .fold((Vec3::ZERO, 0u32), |(s, c), &u| (s + u, c + 1));
                (n, sum / count as f32)
            })
            .collect();
        last = added.iter().map(|&(n, _)| n).collect();
        voxels.extend(added);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::{Transform, MASK_WORDS};

    /// A grid of `n`³ voxels of size `dx` from the origin holding `field` (world units),
    /// collocated or staggered.
    fn sampled(field: impl Fn(Vec3) -> Vec3, n: i32, dx: f64, staggered: bool) -> VectorGrid {
        let mut grid = VectorGrid {
            name: "vel".into(),
            staggered,
            transform: Transform::uniform(dx, [0.0; 3]),
            uniform_linear: true,
            background: [0.0; 3],
            leaf_origins: Vec::new(),
            leaf_values: Vec::new(),
            leaf_masks: Vec::new(),
            tiles: Vec::new(),
        };
        for lx in 0..n / 8 {
            for ly in 0..n / 8 {
                for lz in 0..n / 8 {
                    let origin = IVec3::new(lx, ly, lz) * 8;
                    grid.leaf_origins.push(origin.to_array());
                    grid.leaf_masks.push([u64::MAX; MASK_WORDS]);
                    for offset in 0..LEAF_VOXELS {
                        let v = (origin + crate::grid::offset_coords(offset)).as_vec3();
                        let value: [f32; 3] = std::array::from_fn(|c| {
                            let mut p = v;
                            if staggered {
                                p[c] -= 0.5;
                            }
                            field(p * dx as f32)[c]
                        });
                        grid.leaf_values.push(value);
                    }
                }
            }
        }
        grid
    }

    #[test]
    fn collocated_and_staggered_grids_give_back_a_linear_field() {
        // A rotation plus a stretch: linear, so trilinear sampling is exact wherever the
        // corners are present; read with the other layout, it is off by half a voxel.
        let field = |p: Vec3| Vec3::new(0.8 * p.x - p.y, p.x + 0.5 * p.y, 0.5 * p.x + p.z - 0.2);
        for staggered in [false, true] {
            let grid = sampled(field, 32, 0.05, staggered);
            let flow = GridFlow::new(&grid, 1.0, 0.0).unwrap();
            let wrong = GridFlow::new(
                &VectorGrid {
                    staggered: !staggered,
                    ..grid.clone()
                },
                1.0,
                0.0,
            )
            .unwrap();
            for p in [Vec3::new(0.5, 0.7, 0.9), Vec3::new(1.03, 0.41, 0.77)] {
                let (got, want) = (flow.velocity(p), field(p));
                assert!((got - want).length() < 1e-4, "{staggered}: {got} vs {want}");
                assert!((wrong.velocity(p) - want).length() > 0.01);
            }
        }
    }

    #[test]
    fn velocity_is_extended_past_the_active_voxels() {
        let field = |_: Vec3| Vec3::new(1.0, 2.0, 3.0);
        let flow = GridFlow::new(&sampled(field, 16, 0.1, false), 2.0, 0.0).unwrap();
        // Two voxels past the grid's last voxel (index 15): carried by the extension.
        let outside = Vec3::new(1.7, 0.5, 0.5);
        assert!((flow.velocity(outside) - Vec3::new(2.0, 4.0, 6.0)).length() < 1e-5);
        // Ten voxels past: beyond the fixed layers, so still.
        let further = Vec3::new(2.5, 0.5, 0.5);
        assert_eq!(flow.velocity(further), Vec3::ZERO);
        // Far away: nothing.
        assert_eq!(flow.velocity(Vec3::splat(5.0)), Vec3::ZERO);
        // Over a frame of 0.1 s the fastest voxel travels 7.5 voxels (|v| = 7.48 m/s at
        // Δx 0.1): the extension follows it, so the ten-voxel point moves, and one a
        // hundred voxels out is still left alone.
        let frame = GridFlow::new(&sampled(field, 16, 0.1, false), 2.0, 0.1).unwrap();
        assert!((frame.velocity(further) - Vec3::new(2.0, 4.0, 6.0)).length() < 1e-5);
        assert_eq!(frame.velocity(Vec3::splat(11.0)), Vec3::ZERO);
        // A runaway voxel extends by the cap, not by its speed.
        let runaway = GridFlow::new(&sampled(field, 16, 0.1, false), 1e6, 0.1).unwrap();
        let past_cap = Vec3::new(
            1.5 + 0.1 * f32::from(EXTENSION_LAYERS as u16 + MAX_MOTION_LAYERS as u16 + 2),
            0.5,
            0.5,
        );
        assert_eq!(runaway.velocity(past_cap), Vec3::ZERO);
    }
}
