//! A VDB grid's content in plain Rust, leaf by leaf in OpenVDB's own layout: what the core
//! imports targets from and exports skins to, and what the bridge ([`crate::vdb`], feature
//! `vdb`) copies to and from OpenVDB with one copy of 512 values and 8 mask words per leaf.

pub mod units;

/// Voxels per leaf (8³), in OpenVDB's order: offset = (x & 7) << 6 | (y & 7) << 3 | (z & 7).
pub const LEAF_VOXELS: usize = 512;
/// Words of a leaf's active mask; bit `offset % 64` of word `offset / 64`.
pub const MASK_WORDS: usize = 8;

/// OpenVDB's `GridClass`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GridClass {
    Unknown,
    LevelSet,
    FogVolume,
    Staggered,
}

/// A constant region of the tree above leaf level: 8³ (level 1), 128³ (level 2) or 4096³
/// (root) voxels. Inactive tiles are what keep inside and outside apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tile {
    /// Its lowest voxel, index coordinates.
    pub origin: [i32; 3],
    /// Its side in voxels.
    pub dim: u32,
    /// Every voxel's value.
    pub value: f32,
    /// Whether its voxels are active (a fog's filled region); a level set's inside
    /// tiles are inactive.
    pub active: bool,
}

/// An affine index-to-world map, row-major in OpenVDB's row-vector convention
/// (world = [i j k 1] · M).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// 4×4, row-major: rows 0–2 the index axes in world units, row 3 the translation.
    pub matrix: [f64; 16],
}

impl Transform {
    /// Voxels of side `voxel_size` with index (0,0,0) centred at `origin`.
    pub fn uniform(voxel_size: f64, origin: [f64; 3]) -> Self {
        let d = voxel_size;
        #[rustfmt::skip]
        let matrix = [
            d, 0.0, 0.0, 0.0,
            0.0, d, 0.0, 0.0,
            0.0, 0.0, d, 0.0,
            origin[0], origin[1], origin[2], 1.0,
        ];
        Transform { matrix }
    }

    /// Length of one index step along x, in world units.
    pub fn voxel_size(&self) -> f64 {
        let m = &self.matrix;
        (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt()
    }

    /// `(voxel size, origin)` when index space maps to world space by a positive uniform
    /// scale and a translation alone (no rotation, shear or mirror).
    pub fn scale_translate(&self) -> Option<(f64, [f64; 3])> {
        let m = &self.matrix;
        let d = m[0];
        let linear = (0..3).all(|r| (0..4).all(|c| m[4 * r + c] == if r == c { d } else { 0.0 }));
        (d > 0.0 && linear && m[15] == 1.0).then_some((d, [m[12], m[13], m[14]]))
    }

    /// The world position of index coordinates `ijk`.
    pub fn index_to_world(&self, ijk: [f64; 3]) -> [f64; 3] {
        let m = &self.matrix;
        std::array::from_fn(|c| ijk[0] * m[c] + ijk[1] * m[4 + c] + ijk[2] * m[8 + c] + m[12 + c])
    }
}

/// A float grid copied into Rust, leaf by leaf.
#[derive(Debug, Clone, PartialEq)]
pub struct GridData {
    /// The grid's name in its file (`surface`, `density`, Mantaflow's `phi`).
    pub name: String,
    /// What its values are (OpenVDB's grid class metadata).
    pub class: GridClass,
    /// The value wherever nothing is stored (a level set's: its band's half-width).
    pub background: f32,
    /// Index to world.
    pub transform: Transform,
    /// True when the transform is linear with one scale on all axes.
    pub uniform_linear: bool,
    /// Each 8³ leaf's lowest voxel, index coordinates.
    pub leaf_origins: Vec<[i32; 3]>,
    /// `LEAF_VOXELS` values per leaf, leaves in the order of `leaf_origins`.
    pub leaf_values: Vec<f32>,
    /// Each leaf's active voxels, a bit per voxel in OpenVDB's order (x·64 + y·8 + z).
    pub leaf_masks: Vec<[u64; MASK_WORDS]>,
    /// Constant regions above leaf level; inactive tiles equal to the background are
    /// implied and left out.
    pub tiles: Vec<Tile>,
}

impl GridData {
    /// A grid with no leaves or tiles yet, on a uniform linear `transform`.
    pub fn empty(name: &str, class: GridClass, background: f32, transform: Transform) -> Self {
        GridData {
            name: name.into(),
            class,
            background,
            transform,
            uniform_linear: true,
            leaf_origins: Vec::new(),
            leaf_values: Vec::new(),
            leaf_masks: Vec::new(),
            tiles: Vec::new(),
        }
    }

    /// Appends a leaf: its origin (a multiple of 8), `LEAF_VOXELS` values in OpenVDB's
    /// order, its active mask.
    pub fn push_leaf(&mut self, origin: [i32; 3], values: &[f32], mask: [u64; MASK_WORDS]) {
        assert_eq!(values.len(), LEAF_VOXELS, "a leaf holds 8³ values");
        self.leaf_origins.push(origin);
        self.leaf_values.extend_from_slice(values);
        self.leaf_masks.push(mask);
    }

    pub fn leaf_count(&self) -> usize {
        self.leaf_origins.len()
    }

    /// The voxels of its leaves' box, one leaf wider on every side (inclusive); `None`
    /// without leaves.
    fn leaf_box(&self) -> Option<([i32; 3], [i32; 3])> {
        let mut origins = self.leaf_origins.iter();
        let first = *origins.next()?;
        let (lo, hi) = origins.fold((first, first), |(lo, hi), o| {
            (
                std::array::from_fn(|a| lo[a].min(o[a])),
                std::array::from_fn(|a| hi[a].max(o[a])),
            )
        });
        Some((lo.map(|c| c - 8), hi.map(|c| c + 15)))
    }

    /// Its tiles with the inside ones (negative: a level set's) larger than a leaf cut to
    /// the leaves' box one leaf wider (split into the tiles of the next level down where
    /// they cross its faces); `None` when none reaches past it, the tiles as they are. An
    /// inside that reaches past the leaves comes from a band left open and then
    /// flood-filled (a liquid clipped by its domain, a sphere by the box it was sampled
    /// in: thousands of 128³ tiles out to the tree's edge); read so, it is closed where its
    /// leaves end, as a dense grid's walls are, not at those tiles' far faces — no surface
    /// anyone sampled, and one of millions of blocks (6.5 GB for a 134 KB file).
    pub fn tiles_within_leaves(&self) -> Option<Vec<Tile>> {
        let (lo, hi) = self.leaf_box()?;
        let within = |t: &Tile| {
            let (a, d) = (t.origin, t.dim as i32);
            (0..3).all(|k| a[k] >= lo[k] && a[k] + d - 1 <= hi[k])
        };
        let to_cut = |t: &Tile| t.value < 0.0 && t.dim > 8 && !within(t);
        if !self.tiles.iter().any(to_cut) {
            return None;
        }
        let mut kept = Vec::with_capacity(self.tiles.len());
        let mut stack: Vec<Tile> = Vec::new();
        for &tile in &self.tiles {
            if !to_cut(&tile) {
                kept.push(tile);
                continue;
            }
            stack.push(tile);
            while let Some(t) = stack.pop() {
                let d = t.dim as i32;
                let a = t.origin;
                if within(&t) {
                    kept.push(t);
                    continue;
                }
                // The box's faces are a leaf's: a leaf-sized tile is in it or out.
                let apart = (0..3).any(|k| a[k] > hi[k] || a[k] + d - 1 < lo[k]);
                if apart || d <= 8 {
                    continue;
                }
                let child = if d > 128 { 128 } else { 8 };
                let n = d / child;
                for x in 0..n {
                    for y in 0..n {
                        for z in 0..n {
                            stack.push(Tile {
                                origin: [a[0] + x * child, a[1] + y * child, a[2] + z * child],
                                dim: child as u32,
                                ..t
                            });
                        }
                    }
                }
            }
        }
        Some(kept)
    }

    /// The index coordinates and value of each active voxel of the leaves (not tiles).
    pub fn active_voxels(&self) -> impl Iterator<Item = ([i32; 3], f32)> + '_ {
        active_in_leaves(&self.leaf_origins, &self.leaf_masks)
            .map(|(at, ijk)| (ijk, self.leaf_values[at]))
    }

    /// The index-space gradient of the values at each active voxel of the leaves, in
    /// [`GridData::active_voxels`]' order: central differences between active
    /// neighbours, one-sided where one side is inactive (a band's edge), 0 along an axis
    /// where both are. Values per voxel: divide by the voxel size for world units.
    pub fn active_gradients(&self) -> Vec<[f32; 3]> {
        use rayon::prelude::*;
        let leaves: hashbrown::HashMap<[i32; 3], usize> = self
            .leaf_origins
            .iter()
            .enumerate()
            .map(|(i, &o)| (o, i))
            .collect();
        let value = |ijk: [i32; 3]| -> Option<f32> {
            let leaf = *leaves.get(&ijk.map(|c| c & !7))?;
            let n = ((ijk[0] & 7) << 6 | (ijk[1] & 7) << 3 | (ijk[2] & 7)) as usize;
            let active = self.leaf_masks[leaf][n >> 6] >> (n & 63) & 1 == 1;
            active.then(|| self.leaf_values[leaf * LEAF_VOXELS + n])
        };
        (0..self.leaf_origins.len())
            .into_par_iter()
            .flat_map_iter(|leaf| {
                let origins = &self.leaf_origins[leaf..leaf + 1];
                let masks = &self.leaf_masks[leaf..leaf + 1];
                active_in_leaves(origins, masks).map(move |(n, ijk)| {
                    let here = self.leaf_values[leaf * LEAF_VOXELS + n];
                    std::array::from_fn(|axis| {
                        let step = |d: i32| {
                            let mut at = ijk;
                            at[axis] += d;
                            value(at)
                        };
                        match (step(-1), step(1)) {
                            (Some(below), Some(above)) => 0.5 * (above - below),
                            (Some(below), None) => here - below,
                            (None, Some(above)) => above - here,
                            (None, None) => 0.0,
                        }
                    })
                })
            })
            .collect()
    }

    pub fn leaf_values(&self, leaf: usize) -> &[f32] {
        &self.leaf_values[leaf * LEAF_VOXELS..(leaf + 1) * LEAF_VOXELS]
    }

    pub fn active_voxel_count(&self) -> u64 {
        let in_leaves: u64 = self
            .leaf_masks
            .iter()
            .flatten()
            .map(|w| u64::from(w.count_ones()))
            .sum();
        let in_tiles: u64 = self
            .tiles
            .iter()
            .filter(|t| t.active)
            .map(|t| u64::from(t.dim).pow(3))
            .sum();
        in_leaves + in_tiles
    }
}

/// The leaves of a dense `dims` block of values from index (0,0,0), `values[(i·ny + j)·nz
/// + k]` at voxel (i, j, k) (a C-ordered `(nx, ny, nz)` array): every voxel of the block
/// active, the leaves' voxels past it inactive and `pad`.
fn dense_leaves<T: Copy>(
    dims: [usize; 3],
    values: &[T],
    pad: T,
) -> (Vec<[i32; 3]>, Vec<T>, Vec<[u64; MASK_WORDS]>) {
    assert_eq!(
        values.len(),
        dims.iter().product::<usize>(),
        "one value per voxel"
    );
    let leaves = dims.map(|n| n.div_ceil(8));
    let (mut origins, mut out, mut masks) = (Vec::new(), Vec::new(), Vec::new());
    for li in 0..leaves[0] {
        for lj in 0..leaves[1] {
            for lk in 0..leaves[2] {
                let origin = [li, lj, lk].map(|l| 8 * l);
                let mut mask = [0u64; MASK_WORDS];
                for n in 0..LEAF_VOXELS {
                    let [i, j, k] = [
                        origin[0] + (n >> 6),
                        origin[1] + ((n >> 3) & 7),
                        origin[2] + (n & 7),
                    ];
                    if i < dims[0] && j < dims[1] && k < dims[2] {
                        out.push(values[(i * dims[1] + j) * dims[2] + k]);
                        mask[n >> 6] |= 1 << (n & 63);
                    } else {
                        out.push(pad);
                    }
                }
                origins.push(origin.map(|c| c as i32));
                masks.push(mask);
            }
        }
    }
    (origins, out, masks)
}

impl GridData {
    /// A dense block of `dims` values (C order, [`dense_leaves`]) with voxel (0,0,0) at
    /// `transform`'s origin, as a simulation or numpy holds a grid: every voxel active.
    /// The leaves' voxels past the block, and the background, are `outside`.
    pub fn from_dense(
        name: &str,
        class: GridClass,
        (dims, values): ([usize; 3], &[f32]),
        transform: Transform,
        outside: f32,
    ) -> Self {
        let (leaf_origins, leaf_values, leaf_masks) = dense_leaves(dims, values, outside);
        GridData {
            leaf_origins,
            leaf_values,
            leaf_masks,
            ..GridData::empty(name, class, outside, transform)
        }
    }
}

impl VectorGrid {
    /// A dense, collocated block of vectors, as [`GridData::from_dense`]; zero past it.
    pub fn from_dense(
        name: &str,
        (dims, values): ([usize; 3], &[[f32; 3]]),
        transform: Transform,
    ) -> Self {
        let (leaf_origins, leaf_values, leaf_masks) = dense_leaves(dims, values, [0.0; 3]);
        VectorGrid {
            name: name.into(),
            staggered: false,
            transform,
            uniform_linear: true,
            background: [0.0; 3],
            leaf_origins,
            leaf_values,
            leaf_masks,
            tiles: Vec::new(),
        }
    }
}

/// The background of a narrow band `half_width` voxels of `voxel_size` wide: the smallest
/// f32 not below `half_width · voxel_size` computed in f64, as OpenVDB's checkLevelSet
/// compares it (an f32 product can round a hair under 3 voxels and be rejected).
pub fn narrow_band_background(half_width: f32, voxel_size: f32) -> f32 {
    let exact = f64::from(half_width) * f64::from(voxel_size);
    let mut background = exact as f32;
    while f64::from(background) < exact {
        background = f32::from_bits(background.to_bits() + 1);
    }
    background
}

/// A vector grid (a velocity) copied from VDB, leaf by leaf: `LEAF_VOXELS` vectors per
/// leaf. In a staggered (MAC) grid, component i of voxel v sits on v's lower face along i,
/// at v − ½ e_i in index space; in a collocated grid all three sit at v.
#[derive(Debug, Clone, PartialEq)]
pub struct VectorGrid {
    /// The grid's name in its file (`vel`, Mantaflow's `velocity`).
    pub name: String,
    /// Whether its components sit on the voxels' faces (MAC), as said above.
    pub staggered: bool,
    /// Index to world.
    pub transform: Transform,
    /// True when the transform is linear with one scale on all axes.
    pub uniform_linear: bool,
    /// The vector wherever nothing is stored.
    pub background: [f32; 3],
    /// Each 8³ leaf's lowest voxel, index coordinates.
    pub leaf_origins: Vec<[i32; 3]>,
    /// `LEAF_VOXELS` vectors per leaf, leaves in the order of `leaf_origins`.
    pub leaf_values: Vec<[f32; 3]>,
    /// Each leaf's active voxels, a bit per voxel in OpenVDB's order (x·64 + y·8 + z).
    pub leaf_masks: Vec<[u64; MASK_WORDS]>,
    /// Active constant regions above leaf level.
    pub tiles: Vec<VectorTile>,
}

impl VectorGrid {
    /// The index coordinates and value of each active voxel of the leaves (not tiles).
    pub fn active_voxels(&self) -> impl Iterator<Item = ([i32; 3], [f32; 3])> + '_ {
        active_in_leaves(&self.leaf_origins, &self.leaf_masks)
            .map(|(at, ijk)| (ijk, self.leaf_values[at]))
    }
}

/// Each active voxel of leaves at `origins` with masks `masks`: its index among the
/// leaves' values (`LEAF_VOXELS` a leaf) and its index coordinates, in OpenVDB's order
/// within a leaf (offset = x·64 + y·8 + z, local coordinates).
fn active_in_leaves<'a>(
    origins: &'a [[i32; 3]],
    masks: &'a [[u64; MASK_WORDS]],
) -> impl Iterator<Item = (usize, [i32; 3])> + 'a {
    origins
        .iter()
        .zip(masks)
        .enumerate()
        .flat_map(|(leaf, (origin, mask))| {
            (0..LEAF_VOXELS)
                .filter(|&n| mask[n >> 6] >> (n & 63) & 1 == 1)
                .map(move |n| {
                    let local = [n >> 6, (n >> 3) & 7, n & 7].map(|c| c as i32);
                    let ijk = std::array::from_fn(|c| origin[c] + local[c]);
                    (leaf * LEAF_VOXELS + n, ijk)
                })
        })
}

/// An active constant region of a vector grid: `dim`³ voxels from `origin`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VectorTile {
    /// Its lowest voxel, index coordinates.
    pub origin: [i32; 3],
    /// Its side in voxels.
    pub dim: u32,
    /// Every voxel's vector.
    pub value: [f32; 3],
}

#[cfg(test)]
mod tests {
    use super::{GridClass, GridData, Transform, LEAF_VOXELS, MASK_WORDS};

    #[test]
    fn only_axis_aligned_positive_uniform_voxels_are_a_scale_and_translation() {
        let xf = Transform::uniform(0.25, [1.0, -2.0, 3.0]);
        assert_eq!(xf.scale_translate(), Some((0.25, [1.0, -2.0, 3.0])));
        let (c, s) = (0.6, 0.8);
        let mut rotated = xf;
        rotated.matrix[..2].copy_from_slice(&[0.25 * c, 0.25 * s]);
        rotated.matrix[4..6].copy_from_slice(&[-0.25 * s, 0.25 * c]);
        assert_eq!(rotated.scale_translate(), None);
        let mut mirrored = xf;
        mirrored.matrix[0] = -0.25;
        assert_eq!(mirrored.scale_translate(), None);
        let mut stretched = xf;
        stretched.matrix[10] = 0.5;
        assert_eq!(stretched.scale_translate(), None);
        let mut flipped = xf;
        for i in [0, 5, 10] {
            flipped.matrix[i] = -0.25;
        }
        assert_eq!(flipped.scale_translate(), None);
    }

    /// Two leaves side by side along x hold φ = 2x + 3y (in voxels), the second with
    /// its last x-row inactive: the gradient is (2, 3, 0) on every active voxel, across
    /// the leaves' seam and at the band's edges (one-sided there), in active_voxels'
    /// order.
    #[test]
    fn gradients_cross_leaves_and_stop_at_the_band() {
        let mut data = GridData::empty(
            "g",
            GridClass::LevelSet,
            3.0,
            Transform::uniform(1.0, [0.0; 3]),
        );
        for origin in [[0, 0, 0], [8, 0, 0]] {
            let mut mask = [u64::MAX; MASK_WORDS];
            let values: Vec<f32> = (0..LEAF_VOXELS)
                .map(|n| {
                    let (x, y) = ((n >> 6) as i32 + origin[0], ((n >> 3) & 7) as i32);
                    if x == 15 {
                        // Inactive: the background, as a band's outside holds.
                        mask[n >> 6] &= !(1 << (n & 63));
                        return 3.0;
                    }
                    (2 * x + 3 * y) as f32
                })
                .collect();
            data.push_leaf(origin, &values, mask);
        }
        let gradients = data.active_gradients();
        let voxels: Vec<([i32; 3], f32)> = data.active_voxels().collect();
        assert_eq!(gradients.len(), voxels.len());
        assert_eq!(voxels.len(), 2 * LEAF_VOXELS - 64);
        for (g, (ijk, _)) in gradients.iter().zip(&voxels) {
            assert_eq!(*g, [2.0, 3.0, 0.0], "{ijk:?}");
        }
    }
}
