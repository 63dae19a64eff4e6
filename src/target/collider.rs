//! The liquid meeting a collider (`--collider`): particles stop about a radius off a
//! wall, so a skin closes into a rounded shell there; rendered behind glass or against an
//! obstacle, the liquid should touch it. Where the skin comes within `gap` of the
//! collider, its level set is carried straight on along the collider's normal into it
//! (whatever liquid lies within `gap` over a point of the wall reaches down to it; none
//! is taken away) and cut `depth` inside:
//! the surface meets the collider's face (depth 0) or runs into it so that a renderer's
//! liquid and glass overlap. Away from the collider nothing changes. The skin itself is
//! not touched: this makes the level set the outputs mesh.

use glam::{IVec3, Vec3};
use hashbrown::{HashMap, HashSet};
use rayon::prelude::*;

use std::sync::Arc;

use super::{LevelSetTarget, Target};
use crate::grid::offset_coords;
use crate::volume::{GridData, Tile, LEAF_VOXELS, MASK_WORDS};

/// A collider as the liquid's grid sees it: its signed distance at the grid's nodes, each
/// sampled once and kept while the collider and the grid stay (a static tank is sampled
/// where the liquid comes near it, once for the shot), read between them trilinearly.
/// A block whose centre is farther than the gap and its half diagonal holds one value,
/// a bound below its nodes' (all past the gap: nothing there meets the collider). A node
/// not kept is found the same way when asked: what a frame meets never depends on the
/// frames before it.
pub struct ColliderGrid {
    target: Arc<dyn Target>,
    origin: Vec3,
    dx: f32,
    gap: f32,
    blocks: HashMap<IVec3, Kept>,
}

/// A block's distances to the collider.
enum Kept {
    /// Within reach: each node's.
    Near(Box<[f32; LEAF_VOXELS]>),
    /// Beyond the gap: a bound below every node's.
    Far(f32),
}

impl ColliderGrid {
    /// `target` on the grid of voxel `dx` whose node (0, 0, 0) is at `origin`, met within
    /// `gap`.
    pub fn new(target: Arc<dyn Target>, origin: Vec3, dx: f32, gap: f32) -> Self {
        ColliderGrid {
            target,
            origin,
            dx,
            gap,
            blocks: HashMap::new(),
        }
    }

    /// Whether this is `target` on the grid of `origin` and `dx` met within `gap` (its
    /// nodes can be kept).
    pub fn is_on(&self, target: &Arc<dyn Target>, origin: Vec3, dx: f32, gap: f32) -> bool {
        Arc::ptr_eq(&self.target, target)
            && self.origin == origin
            && self.dx == dx
            && self.gap == gap
    }

    fn world(&self, ijk: IVec3) -> Vec3 {
        self.origin + ijk.as_vec3() * self.dx
    }

    /// Block `b`'s distances.
    fn sample_block(&self, b: IVec3) -> Kept {
        let half_diagonal = 0.5 * 3f32.sqrt() * 7.0 * self.dx;
        let centre = self
            .target
            .distance(self.world(b * 8) + Vec3::splat(3.5 * self.dx));
        if centre > self.gap + half_diagonal + self.dx {
            return Kept::Far(centre - half_diagonal);
        }
        let mut values = Box::new([0.0; LEAF_VOXELS]);
        for (o, v) in values.iter_mut().enumerate() {
            *v = self.target.distance(self.world(b * 8 + offset_coords(o)));
        }
        Kept::Near(values)
    }

    /// Samples the blocks of `blocks` not yet kept, and the blocks around those within
    /// reach the walk out to the gap may read.
    fn keep(&mut self, blocks: &[IVec3]) {
        self.keep_only(blocks);
        let ring = (self.gap / (8.0 * self.dx)).ceil() as i32;
        let mut around: Vec<IVec3> = blocks
            .iter()
            .filter(|b| matches!(self.blocks.get(*b), Some(Kept::Near(_))))
            .flat_map(|&b| {
                (-ring..=ring).flat_map(move |x| {
                    (-ring..=ring)
                        .flat_map(move |y| (-ring..=ring).map(move |z| b + IVec3::new(x, y, z)))
                })
            })
            .filter(|b| !self.blocks.contains_key(b))
            .collect();
        around.sort_unstable_by_key(|b| b.to_array());
        around.dedup();
        self.keep_only(&around);
    }

    fn keep_only(&mut self, blocks: &[IVec3]) {
        let missing: Vec<IVec3> = blocks
            .iter()
            .filter(|b| !self.blocks.contains_key(*b))
            .copied()
            .collect();
        let this = &*self;
        let sampled: Vec<(IVec3, Kept)> = missing
            .into_par_iter()
            .map(|b| (b, this.sample_block(b)))
            .collect();
        self.blocks.extend(sampled);
    }

    /// The distance at node `ijk` (a far block's bound).
    fn node(&self, ijk: IVec3) -> f32 {
        let at = |kept: &Kept| match kept {
            Kept::Near(values) => {
                let l = ijk & 7;
                values[((l.x << 6) | (l.y << 3) | l.z) as usize]
            }
            Kept::Far(bound) => *bound,
        };
        match self.blocks.get(&(ijk >> 3)) {
            Some(kept) => at(kept),
            None => at(&self.sample_block(ijk >> 3)),
        }
    }

    /// The distance at `p` and its direction of growth, trilinear in `p`'s cell (exact for
    /// a plane; a wall's normal without the six extra samples of a central difference).
    fn sample(&self, p: Vec3) -> (f32, Vec3) {
        let q = (p - self.origin) / self.dx;
        let base = q.floor();
        let (t, b) = (q - base, base.as_ivec3());
        let mut c = [0.0f32; 8];
        let corner = |i: usize| IVec3::new(i as i32 >> 2, (i as i32 >> 1) & 1, i as i32 & 1);
        match self.blocks.get(&(b >> 3)) {
            // The cell within one kept block: its eight nodes from one lookup.
            Some(Kept::Near(values)) if (b & 7).cmplt(IVec3::splat(7)).all() => {
                for (i, v) in c.iter_mut().enumerate() {
                    let l = (b & 7) + corner(i);
                    *v = values[((l.x << 6) | (l.y << 3) | l.z) as usize];
                }
            }
            _ => {
                for (i, v) in c.iter_mut().enumerate() {
                    *v = self.node(b + corner(i));
                }
            }
        }
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        // Along z, then y, then x; the gradient from the same corners.
        let (c00, c01) = (lerp(c[0], c[1], t.z), lerp(c[2], c[3], t.z));
        let (c10, c11) = (lerp(c[4], c[5], t.z), lerp(c[6], c[7], t.z));
        let (c0, c1) = (lerp(c00, c01, t.y), lerp(c10, c11, t.y));
        let value = lerp(c0, c1, t.x);
        let dz = |x: usize, y: usize| c[4 * x + 2 * y + 1] - c[4 * x + 2 * y];
        let grad = Vec3::new(
            c1 - c0,
            lerp(c01 - c00, c11 - c10, t.x),
            lerp(
                lerp(dz(0, 0), dz(0, 1), t.y),
                lerp(dz(1, 0), dz(1, 1), t.y),
                t.x,
            ),
        ) / self.dx;
        (value, grad)
    }
}

/// `liquid` (a narrow-band level set on a uniform grid, as [`crate::skin::Skin::to_level_set`]
/// writes it) meeting `collider` (signed distance, negative inside): within `gap` of the
/// collider the liquid's level set is the one `gap` out along the collider's normal, and
/// nothing of the liquid lies more than `depth` inside the collider. `None` when the
/// liquid is nowhere within `gap` of the collider (nothing to change). `collider` must be
/// on the liquid's grid ([`ColliderGrid::is_on`]).
pub fn meet_collider(
    liquid: &GridData,
    collider: &mut ColliderGrid,
    gap: f32,
    depth: f32,
) -> Option<GridData> {
    let dx = liquid.transform.voxel_size() as f32;
    let origin = liquid_origin(liquid);
    debug_assert!(collider.origin == origin && collider.dx == dx);
    let background = liquid.background;
    let sample = LevelSetTarget::new(liquid);
    // The liquid's blocks (leaves and inside tiles, leaf-sized), and the blocks around
    // them the extension can reach.
    let leaves: HashMap<IVec3, usize> = liquid
        .leaf_origins
        .iter()
        .enumerate()
        .map(|(i, o)| (IVec3::from(*o) / 8, i))
        .collect();
    let tiles: HashSet<IVec3> = leaf_sized_tiles(liquid);
    // The blocks within the gap of the collider's surface (a level set's leaves and
    // inside tiles, a mesh's cells: beyond them it is far) that have liquid within reach.
    let reach = ((gap + depth) / (8.0 * dx)).ceil() as i32 + 1;
    let block_of = |p: Vec3| ((p - origin) / (8.0 * dx)).floor().as_ivec3();
    let mut near: Vec<IVec3> = collider
        .target
        .surface_parts()
        .iter()
        .flat_map(|part| {
            let (lo, hi) = (
                block_of(part.min - Vec3::splat(gap + dx)),
                block_of(part.max + Vec3::splat(gap + dx)),
            );
            (lo.x..=hi.x).flat_map(move |x| {
                (lo.y..=hi.y).flat_map(move |y| (lo.z..=hi.z).map(move |z| IVec3::new(x, y, z)))
            })
        })
        .collect();
    near.sort_unstable_by_key(|b| b.to_array());
    near.dedup();
    let liquid_near = |b: IVec3| {
        (-reach..=reach).any(|x| {
            (-reach..=reach).any(|y| {
                (-reach..=reach).any(|z| {
                    let n = b + IVec3::new(x, y, z);
                    leaves.contains_key(&n) || tiles.contains(&n)
                })
            })
        })
    };
    let candidates: Vec<IVec3> = near.into_par_iter().filter(|&b| liquid_near(b)).collect();
    debug_assert!(collider.gap == gap);
    collider.keep(&candidates);
    let collider = &*collider;
    let changed: Vec<(IVec3, Option<[f32; LEAF_VOXELS]>, bool)> = candidates
        .par_iter()
        .filter_map(|&b| {
            let Kept::Near(kept) = &collider.blocks[&b] else {
                return None; // beyond the collider's reach: as it is
            };
            if kept.iter().all(|&c| c >= gap) {
                return None; // beyond the collider's reach: as it is
            }
            // The node's own value where the collider is beyond the gap.
            let stored = |o: usize| match (leaves.get(&b), tiles.contains(&b)) {
                (Some(&leaf), _) => liquid.leaf_values(leaf)[o],
                (None, true) => -background,
                (None, false) => background,
            };
            let mut values = [background; LEAF_VOXELS];
            let mut moved = false;
            for (o, v) in values.iter_mut().enumerate() {
                let c = kept[o];
                *v = match c >= gap {
                    true => stored(o),
                    false => {
                        let p = collider.world(b * 8 + offset_coords(o));
                        // The union of the node's own liquid and the liquid carried
                        // there (a film thinner than the gap lying on the collider
                        // stays), cut `depth` inside the collider.
                        let cut = -(c + depth);
                        let liquid = match (cut > 0.0, stored(o)) {
                            (true, _) => -background, // past the depth: only the cut counts
                            (false, own) if own <= -background => own,
                            (false, own) => {
                                own.min(carried(p, c, &sample, collider, (gap, background)))
                            }
                        };
                        liquid.max(cut).clamp(-background, background)
                    }
                };
                // A node near the surface whose value changed moves it.
                let was = stored(o);
                moved |=
                    (*v < 0.0) != (was < 0.0) || (*v != was && (v.abs() < dx || was.abs() < dx));
            }
            let outside = values.iter().all(|&v| v >= background);
            let was = leaves.contains_key(&b) || tiles.contains(&b);
            match (outside, was) {
                (true, false) => None,
                (true, true) => Some((b, None, moved)),
                _ => Some((b, Some(values), moved)),
            }
        })
        .collect();
    // Nothing to change unless the surface moves.
    if !changed.iter().any(|&(.., moved)| moved) {
        return None;
    }
    let changed = changed.into_iter().map(|(b, v, _)| (b, v)).collect();
    Some(rebuilt(liquid, &leaves, &tiles, changed))
}

/// Where `liquid`'s node (0, 0, 0) is in the world.
pub fn liquid_origin(liquid: &GridData) -> Vec3 {
    Vec3::from(liquid.transform.index_to_world([0.0; 3]).map(|c| c as f32))
}

/// The liquid carried to `p`, `c` from the collider (less than `gap`): the least of the
/// liquid's level set along the way from `p` out along the collider's normal to `gap` —
/// whatever liquid lies within the gap over `p`, a body's face or a film thinner than the
/// gap, reaches down to it.
fn carried(
    p: Vec3,
    c: f32,
    liquid: &LevelSetTarget,
    collider: &ColliderGrid,
    (gap, background): (f32, f32),
) -> f32 {
    // Out along the collider's normal to `gap`, again from there while another face of
    // it (a floor under a wall) is still nearer: into a corner, the liquid is carried
    // from where it is clear of both.
    let (mut q, (mut at, mut normal)) = (p, collider.sample(p));
    debug_assert!((at - c).abs() <= 1e-6 * c.abs().max(1.0));
    let step = collider.dx;
    let mut least = f32::INFINITY;
    for _ in 0..4 {
        if at >= gap {
            break;
        }
        let leg = normal.normalize_or_zero() * (gap - at);
        let n = (leg.length() / step).ceil().max(1.0);
        for k in 1..=n as u32 {
            least = least.min(liquid.trilinear(q + leg * (k as f32 / n)));
        }
        if least <= -background {
            break; // as deep as a level set says
        }
        q += leg;
        (at, normal) = collider.sample(q);
    }
    least
}

/// The liquid's inside tiles as leaf-sized blocks (the skin writes them so; larger ones,
/// from other writers, are split).
fn leaf_sized_tiles(liquid: &GridData) -> HashSet<IVec3> {
    let mut blocks = HashSet::new();
    for t in liquid.tiles.iter().filter(|t| t.value < 0.0) {
        let (o, n) = (IVec3::from(t.origin), t.dim as i32 / 8);
        for x in 0..n {
            for y in 0..n {
                for z in 0..n {
                    blocks.insert(o / 8 + IVec3::new(x, y, z));
                }
            }
        }
    }
    blocks
}

/// `liquid` with each changed block's values (`None`: outside, left to the background).
fn rebuilt(
    liquid: &GridData,
    leaves: &HashMap<IVec3, usize>,
    tiles: &HashSet<IVec3>,
    changed: Vec<(IVec3, Option<[f32; LEAF_VOXELS]>)>,
) -> GridData {
    let background = liquid.background;
    let replaced: HashMap<IVec3, Option<[f32; LEAF_VOXELS]>> = changed.into_iter().collect();
    let mut out = GridData::empty(&liquid.name, liquid.class, background, liquid.transform);
    out.uniform_linear = liquid.uniform_linear;
    let mut push = |b: IVec3, values: &[f32]| {
        if values.iter().all(|&v| v <= -background) {
            out.tiles.push(Tile {
                origin: (b * 8).to_array(),
                dim: 8,
                value: -background,
                active: false,
            });
            return;
        }
        let mut mask = [0u64; MASK_WORDS];
        for (o, v) in values.iter().enumerate() {
            if v.abs() < background {
                mask[o >> 6] |= 1 << (o & 63);
            }
        }
        out.leaf_origins.push((b * 8).to_array());
        out.leaf_values.extend_from_slice(values);
        out.leaf_masks.push(mask);
    };
    let mut order: Vec<IVec3> = leaves
        .keys()
        .chain(tiles.iter())
        .chain(replaced.keys())
        .copied()
        .collect();
    order.sort_unstable_by_key(|b| b.to_array());
    order.dedup();
    let inside = [-background; LEAF_VOXELS];
    for b in order {
        match (replaced.get(&b), leaves.get(&b)) {
            (Some(Some(values)), _) => push(b, values),
            (Some(None), _) => {}
            (None, Some(&leaf)) => push(b, liquid.leaf_values(leaf)),
            (None, None) => push(b, &inside),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::target::BoxShape;
    use crate::volume::{GridClass, Transform};

    /// A slab of liquid standing `off` from a wall at x = 0 (the collider: x < 0), as a
    /// level set of voxel `dx`: the liquid is x ∈ [off, 0.4], |y|, |z| < 0.2.
    fn slab(off: f32, dx: f32) -> GridData {
        film(off, 0.4, dx)
    }

    /// The liquid x ∈ [from, to], |y|, |z| < 0.2, as a level set of voxel `dx`.
    fn film(from: f32, to: f32, dx: f32) -> GridData {
        let background = 3.0 * dx;
        let (lo, hi) = (Vec3::new(from, -0.2, -0.2), Vec3::new(to, 0.2, 0.2));
        let liquid = BoxShape {
            center: 0.5 * (lo + hi),
            half_size: 0.5 * (hi - lo),
        };
        let mut data = GridData::empty(
            "surface",
            GridClass::LevelSet,
            background,
            Transform::uniform(f64::from(dx), [0.0; 3]),
        );
        let n = (0.6 / (8.0 * dx)).ceil() as i32;
        for x in -n..n {
            for y in -n..n {
                for z in -n..n {
                    let b = IVec3::new(x, y, z);
                    let values: Vec<f32> = (0..LEAF_VOXELS)
                        .map(|o| {
                            let p = ((b * 8 + offset_coords(o)).as_vec3()) * dx;
                            liquid.distance(p).clamp(-background, background)
                        })
                        .collect();
                    if values.iter().all(|&v| v >= background) {
                        continue;
                    }
                    if values.iter().all(|&v| v <= -background) {
                        data.tiles.push(Tile {
                            origin: (b * 8).to_array(),
                            dim: 8,
                            value: -background,
                            active: false,
                        });
                        continue;
                    }
                    data.push_leaf((b * 8).to_array(), &values, [u64::MAX; MASK_WORDS]);
                }
            }
        }
        data
    }

    struct Wall;
    impl Target for Wall {
        fn distance(&self, p: Vec3) -> f32 {
            p.x
        }
        fn bounds(&self) -> crate::grid::Aabb {
            crate::grid::Aabb {
                min: Vec3::splat(-1.0),
                max: Vec3::new(0.0, 1.0, 1.0),
            }
        }
    }

    #[test]
    fn a_slab_off_a_wall_is_carried_to_it_and_cut_inside() {
        let dx = 0.02;
        let liquid = slab(0.03, dx);
        let at = |data: &GridData, p: Vec3| LevelSetTarget::new(data).distance(p);
        let wall: Arc<dyn Target> = Arc::new(Wall);
        // Kept across "frames": a slab farther off first, then each depth.
        let mut kept = ColliderGrid::new(wall.clone(), liquid_origin(&liquid), dx, 0.05);
        assert!(meet_collider(&slab(0.045, dx), &mut kept, 0.05, 0.0).is_some());
        for depth in [0.0, 0.01] {
            let mut fresh = ColliderGrid::new(wall.clone(), liquid_origin(&liquid), dx, 0.05);
            let met = meet_collider(&liquid, &mut fresh, 0.05, depth).expect("the slab is near");
            // The nodes kept from the frames before change nothing, bit for bit.
            let again = meet_collider(&liquid, &mut kept, 0.05, depth).unwrap();
            assert_eq!(again.leaf_origins, met.leaf_origins);
            assert!(again
                .leaf_values
                .iter()
                .zip(&met.leaf_values)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
            // Across the slab's middle: the face on the wall's side now at −depth, the
            // far face where it was.
            for y in [-0.1, 0.0, 0.1] {
                let face = |x: f32| at(&met, Vec3::new(x, y, 0.05));
                assert!(
                    face(-depth + 0.2 * dx) < 0.0 && face(-depth - 0.2 * dx) > 0.0,
                    "depth {depth}: {} {}",
                    face(-depth + 0.2 * dx),
                    face(-depth - 0.2 * dx)
                );
                assert!(
                    (at(&met, Vec3::new(0.4, y, 0.0)) - at(&liquid, Vec3::new(0.4, y, 0.0))).abs()
                        < 1e-6
                );
            }
            // The slab's sides run straight on to the wall: at x = 0.01 the liquid's
            // cross-section is the one at the gap.
            let side = |z: f32| at(&met, Vec3::new(0.01, 0.0, z));
            assert!(side(0.19) < 0.0 && side(0.21) > 0.0);
        }
        // A film thinner than the gap lying on the wall (the liquid carried from the gap
        // is air): it stays, and meets the wall.
        let thin = film(0.01, 0.03, dx);
        let mut wall_grid = ColliderGrid::new(wall.clone(), liquid_origin(&thin), dx, 0.05);
        let met = meet_collider(&thin, &mut wall_grid, 0.05, 0.0).expect("the film is near");
        for x in [0.002, 0.01, 0.02, 0.028] {
            assert!(
                at(&met, Vec3::new(x, 0.0, 0.05)) < 0.0,
                "{x}: the film is gone"
            );
        }
        assert!(at(&met, Vec3::new(0.035, 0.0, 0.05)) > 0.0);
        // Liquid farther than the gap from the wall: nothing changes.
        let far = slab(0.1, dx);
        let mut wall = ColliderGrid::new(Arc::new(Wall), liquid_origin(&far), dx, 0.05);
        assert!(meet_collider(&far, &mut wall, 0.05, 0.0).is_none());
    }
}
