//! The liquid meeting a collider (`--collider`): particles stop about a radius off a
//! wall, so a skin closes into a rounded shell there; rendered behind glass or against an
//! obstacle, the liquid should touch it. Where the skin comes within `gap` of the
//! collider, its level set is carried straight on along the collider's normal into it
//! (what the liquid is at `gap` from the wall, it is at the wall) and cut `depth` inside:
//! the surface meets the collider's face (depth 0) or runs into it so that a renderer's
//! liquid and glass overlap. Away from the collider nothing changes. The skin itself is
//! not touched: this makes the level set the outputs mesh.

use glam::{IVec3, Vec3};
use hashbrown::{HashMap, HashSet};
use rayon::prelude::*;

use super::{gradient, LevelSetTarget, Target};
use crate::grid::offset_coords;
use crate::volume::{GridData, Tile, LEAF_VOXELS, MASK_WORDS};

/// `liquid` (a narrow-band level set on a uniform grid, as [`crate::skin::Skin::to_level_set`]
/// writes it) meeting `collider` (signed distance, negative inside): within `gap` of the
/// collider the liquid's level set is the one `gap` out along the collider's normal, and
/// nothing of the liquid lies more than `depth` inside the collider. `None` when the
/// liquid is nowhere within `gap` of the collider (nothing to change).
pub fn meet_collider(
    liquid: &GridData,
    collider: &dyn Target,
    gap: f32,
    depth: f32,
) -> Option<GridData> {
    let dx = liquid.transform.voxel_size() as f32;
    let origin = Vec3::from(liquid.transform.index_to_world([0.0; 3]).map(|c| c as f32));
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
    // The blocks within the gap of the collider's own pieces (its leaves and inside
    // tiles: beyond them it is far) that have liquid within reach.
    let reach = ((gap + depth) / (8.0 * dx)).ceil() as i32 + 1;
    let block_of = |p: Vec3| ((p - origin) / (8.0 * dx)).floor().as_ivec3();
    let mut near: Vec<IVec3> = collider
        .parts()
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
    let half_diagonal = 8.0 * dx * 3f32.sqrt() * 0.5;
    let node = |b: IVec3, o: usize| origin + ((b * 8 + offset_coords(o)).as_vec3()) * dx;
    let changed: Vec<(IVec3, Option<[f32; LEAF_VOXELS]>, bool)> = candidates
        .par_iter()
        .filter_map(|&b| {
            let centre = origin + (b * 8).as_vec3() * dx + Vec3::splat(3.5 * dx);
            if collider.distance(centre) > gap + half_diagonal + dx {
                return None; // beyond the collider's reach: as it is
            }
            // The node's own value where the collider is beyond the gap.
            let stored = |o: usize| match (leaves.get(&b), tiles.contains(&b)) {
                (Some(&leaf), _) => liquid.leaf_values(leaf)[o],
                (None, true) => -background,
                (None, false) => background,
            };
            let mut values = [background; LEAF_VOXELS];
            let mut flipped = false;
            for (o, v) in values.iter_mut().enumerate() {
                let p = node(b, o);
                let c = collider.distance(p);
                *v = match c >= gap {
                    true => stored(o),
                    false => met(p, c, &sample, collider, (gap, depth), (dx, background)),
                };
                flipped |= (*v < 0.0) != (stored(o) < 0.0);
            }
            let outside = values.iter().all(|&v| v >= background);
            let was = leaves.contains_key(&b) || tiles.contains(&b);
            match (outside, was) {
                (true, false) => None,
                (true, true) => Some((b, None, flipped)),
                _ => Some((b, Some(values), flipped)),
            }
        })
        .collect();
    // The surface moves only where a node changes sides.
    if !changed.iter().any(|&(.., flipped)| flipped) {
        return None;
    }
    let changed = changed.into_iter().map(|(b, v, _)| (b, v)).collect();
    Some(rebuilt(liquid, &leaves, &tiles, changed))
}

/// The met level set at `p`, `c` from the collider (less than `gap`): the liquid's
/// carried from `gap` out along the collider's normal, cut `depth` inside it; within
/// ±`background`.
fn met(
    p: Vec3,
    c: f32,
    liquid: &LevelSetTarget,
    collider: &dyn Target,
    (gap, depth): (f32, f32),
    (dx, background): (f32, f32),
) -> f32 {
    if c <= -depth {
        // Past the depth: outside, by as much as the cut says (the liquid carried there
        // would be cut anyway; its value only moved the cap's rim, inside the collider).
        return (-(c + depth)).min(background);
    }
    // Out along the collider's normal to `gap`, again from there while another face of
    // it (a floor under a wall) is still nearer: into a corner, the liquid is carried
    // from where it is clear of both.
    let (mut q, mut at) = (p, c);
    for _ in 0..4 {
        if at >= gap {
            break;
        }
        q += gradient(collider, q, 0.5 * dx).normalize_or_zero() * (gap - at);
        at = collider.distance(q);
    }
    let carried = liquid.distance(q);
    carried.max(-(c + depth)).clamp(-background, background)
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
        let background = 3.0 * dx;
        let (lo, hi) = (Vec3::new(off, -0.2, -0.2), Vec3::new(0.4, 0.2, 0.2));
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
        for depth in [0.0, 0.01] {
            let met = meet_collider(&liquid, &Wall, 0.05, depth).expect("the slab is near");
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
        // Liquid farther than the gap from the wall: nothing changes.
        let far = slab(0.1, dx);
        assert!(meet_collider(&far, &Wall, 0.05, 0.0).is_none());
    }
}
