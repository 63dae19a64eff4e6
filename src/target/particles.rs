//! The density of a particle frame as a target (paper §6.1):
//! `G(X) = Σ W(|X − p_i| / h_i)` with the compact kernel `W(q) = (1 − q²)³` for q < 1,
//! one support h for all particles or one each (from their radii), neighbours found
//! through a hashed grid of cells of side max h_i.

use std::ops::Range;

use glam::{IVec3, Vec3};
use hashbrown::{HashMap, HashSet};
use rayon::prelude::*;

use crate::grid::{offset_coords, AROUND};
use crate::volume::{GridClass, GridData, Transform, LEAF_VOXELS, MASK_WORDS};

use super::Target;

use crate::flow::Flow;
use crate::grid::Aabb;

mod raster;
pub use raster::DensityGrid;

/// The kernel, 1 at the particle and 0 from distance h on, smooth at both ends.
#[inline]
pub fn kernel(q: f32) -> f32 {
    if q >= 1.0 {
        0.0
    } else {
        let s = 1.0 - q * q;
        s * s * s
    }
}

/// Half the kernel's support in particle radii, by default: the support spans two rest
/// spacings (about 33 neighbours), as splashsurf's `-l 2`.
pub const DEFAULT_SMOOTHING_LENGTH: f32 = 2.0;

/// How many times a fluid's neighbourhood at rest a particle's may hold before its
/// own density is summed over cubes of particles instead of pairs
/// ([`Density::normalized`]): never in a simulation, whose densities stay within a few
/// percent of rest.
const CROWD_OVER_REST: f32 = 16.0;

/// The cubes a crowded neighbourhood's particles are gathered in, per support.
const CROWD_CUBES: f32 = 8.0;

/// The support of the kernel that averages the velocities of particles matched from frame
/// to frame, in particle radii ([`Density::velocity_within`]): the skin lies about a radius
/// past the outer particles, and a node there sees mostly the outer layer, whose motion is
/// the surface's. Over the density's own support (4 radii at the default smoothing length)
/// the mean reaches two layers deeper, whose motion is not the surface's: on the
/// SPlisHSPlasH dam break (before the smoothing), the surface's temporal noise was 1.22×
/// splashsurf's against 0.93× over 2.5 radii. With the smoothing, the particles' own jitter
/// carried into the skin is what bumps are left (`activeskin bench --particles`, against
/// smoothed splashsurf): over 2.5 radii the wave's run is 0.88× as bumpy, over 3.25 0.81×
/// (flicker 0.99×, noise 0.92×, sheets 1.63 r), over 3.5 0.80× (flicker 1.01×, sheets
/// 1.56 r), over 4 0.77× (flicker 1.04×, sheets 1.45 r: thinner than the liquid's 2r by
/// more than a quarter). Only for the one-trace carry, which reads it at the nodes near
/// the skin: the velocity stepped in sub-steps (particles with velocities only) is read
/// farther out, where this mean is zero — a ball of VDB points moving 4 voxels a frame
/// then trailed 1.8 voxels.
pub const VELOCITY_SUPPORT_RADII: f32 = 3.25;

/// Spray ([`Density::finding_spray`]): clusters of at most [`SPRAY_MOST`] particles
/// linked by steps of at most this share of the kernel's support (3.25 radii at the
/// default smoothing length) from any other particle. Our kernel's sum joins two
/// particles up to 4.25 radii apart; on a SPlisHSPlasH dam break, the clusters at this
/// link are the droplets smoothed splashsurf shows (3.5 radii: a third of them, 3: half
/// again as many), drops of 2–4 particles 0.2–0.6 r apart, their nearest other
/// particle 3.4–4 r away.
pub const SPRAY_LINK: f32 = 0.8125;

/// The most particles a cluster of spray holds: droplets, not a sheet or a jet.
pub const SPRAY_MOST: usize = 16;

/// The least kernel weight a mean velocity is taken over: less is no particle.
const MIN_VELOCITY_WEIGHT: f32 = 1e-6;

/// The longest smoothing length a density is built with: a support of 32 radii, some
/// 17 000 neighbours a particle. [`rest_density`] and [`fluid_iso`] are NaN beyond (and
/// for lengths that are not positive numbers), as their lattice sums grow with its cube.
pub const MAX_SMOOTHING_LENGTH: f32 = 16.0;

/// The iso value that puts the surface of a lone particle at `radius` with support `h`.
pub fn iso_for_radius(radius: f32, h: f32) -> f32 {
    kernel(radius / h)
}

/// The density of a fluid at rest at one of its particles (itself included): particles
/// of radius r on a lattice of spacing 2r, support 2·`smoothing_length`·r; the same for
/// every r. [`Density::normalized`] divides each particle's kernel by its own density in
/// units of this one.
pub fn rest_density(smoothing_length: f32) -> f32 {
    if !(smoothing_length > 0.0 && smoothing_length <= MAX_SMOOTHING_LENGTH) {
        return f32::NAN;
    }
    // A particle deep in the lattice.
    half_space_density(smoothing_length, Vec3::new(0.0, 0.0, -2001.0), |_| 1.0)
}

/// Σ volume(k)·W at `at` over a half-space lattice (r = 1: spacing 2, layers k = 0, 1, …
/// at z = −1, −3, …; a point deep inside sees the whole lattice).
fn half_space_density(smoothing_length: f32, at: Vec3, volume: impl Fn(i32) -> f32) -> f32 {
    let h = 2.0 * smoothing_length;
    let inv_h2 = 1.0 / (h * h);
    let n = (0.5 * h).ceil() as i32 + 1;
    let (ci, cj) = ((0.5 * at.x).round() as i32, (0.5 * at.y).round() as i32);
    let ck = ((-at.z - 1.0) * 0.5).round() as i32;
    let mut sum = 0.0f64;
    for i in ci - n..=ci + n {
        for j in cj - n..=cj + n {
            for k in (ck - n).max(0)..=ck + n {
                let q = Vec3::new(2.0 * i as f32, 2.0 * j as f32, -1.0 - 2.0 * k as f32);
                let w = kernel(((at - q).length_squared() * inv_h2).sqrt());
                sum += f64::from(volume(k) * w);
            }
        }
    }
    sum as f32
}

/// The iso value that puts the surface of a fluid at rest — particles of radius r on a
/// lattice of spacing 2r, support 2·`smoothing_length`·r, [`Density::normalized`] — on
/// the fluid's boundary, r past its outer layer of particles: the density there,
/// averaged over the boundary plane of a half-space of such particles (each layer's
/// particles normalized by their own density). About 0.6 of the rest density.
pub fn fluid_iso(smoothing_length: f32) -> f32 {
    if !(smoothing_length > 0.0 && smoothing_length <= MAX_SMOOTHING_LENGTH) {
        return f32::NAN;
    }
    let rest = rest_density(smoothing_length);
    let layers = (smoothing_length.ceil() as i32 + 1) as usize;
    let volumes: Vec<f32> = (0..=layers)
        .map(|k| {
            let at = Vec3::new(0.0, 0.0, -1.0 - 2.0 * k as f32);
            rest / half_space_density(smoothing_length, at, |_| 1.0)
        })
        .collect();
    let samples = 16;
    let mut sum = 0.0f64;
    for a in 0..samples {
        for b in 0..samples {
            let x = (a as f32 + 0.5) * 2.0 / samples as f32;
            let y = (b as f32 + 0.5) * 2.0 / samples as f32;
            let volume = |k: i32| volumes.get(k as usize).copied().unwrap_or(1.0);
            sum += f64::from(half_space_density(
                smoothing_length,
                Vec3::new(x, y, 0.0),
                volume,
            ));
        }
    }
    (sum / f64::from(samples * samples)) as f32
}

pub struct Density {
    /// Particles sorted by cell: position and 1/h_i², each cell's run contiguous.
    particles: Vec<(Vec3, f32)>,
    /// Each cell's run in `particles`.
    cells: HashMap<IVec3, (u32, u32)>,
    /// Input index of each particle, in `particles`' order.
    order: Vec<u32>,
    /// Each particle's kernel weight (1 unless [`Density::normalized`]), in `particles`'
    /// order.
    volumes: Vec<f32>,
    /// Each particle's velocity, in `particles`' order (empty when unknown).
    velocities: Vec<Vec3>,
    /// The velocity kernel's support over the density's, at most 1 (see
    /// [`VELOCITY_SUPPORT_RADII`]).
    velocity_support: f32,
    /// The largest support: the cell size.
    h: f32,
    iso: f32,
    bounds: Aabb,
    /// Which particles are spray, in `particles`' order (empty until found).
    spray: Vec<bool>,
    /// [`Density::finding_spray`]'s link and largest cluster.
    spray_rule: Option<(f32, usize)>,
}

impl Density {
    /// `h`: the kernel's support (world units); `iso`: the density of the surface.
    pub fn new(positions: Vec<Vec3>, h: f32, iso: f32) -> Self {
        let supports = vec![h; positions.len()];
        Self::with_supports(positions, supports, iso)
    }

    /// One support per particle: with h_i = 2 r_i and the iso of [`iso_for_radius`]
    /// (r, 2r) — the same for every r — a lone particle's surface sits at its own radius.
    pub fn with_supports(positions: Vec<Vec3>, supports: Vec<f32>, iso: f32) -> Self {
        assert_eq!(positions.len(), supports.len(), "one support per particle");
        let h = supports.iter().copied().fold(0.0f32, f32::max);
        let key = |p: Vec3| (p / h).floor().as_ivec3();
        let mut bounds = Aabb {
            min: Vec3::INFINITY,
            max: Vec3::NEG_INFINITY,
        };
        for &p in &positions {
            bounds.min = bounds.min.min(p);
            bounds.max = bounds.max.max(p);
        }
        // Sorted by cell so that a query reads each neighbour cell's particles in one run;
        // ties by input order, so that sums (and resumed runs) are the same every time.
        let mut particles: Vec<(IVec3, Vec3, f32, u32)> = positions
            .par_iter()
            .zip(supports.par_iter())
            .enumerate()
            .map(|(i, (&p, &s))| (key(p), p, 1.0 / (s * s), i as u32))
            .collect();
        particles.par_sort_unstable_by_key(|(c, .., i)| (c.to_array(), *i));
        let mut cells = HashMap::new();
        let mut start = 0;
        for (end, (c, ..)) in particles.iter().enumerate() {
            if particles.get(end + 1).map_or(true, |next| next.0 != *c) {
                cells.insert(*c, (start as u32, end as u32 + 1));
                start = end + 1;
            }
        }
        Density {
            order: particles.iter().map(|&(.., i)| i).collect(),
            velocities: Vec::new(),
            volumes: vec![1.0; particles.len()],
            velocity_support: 1.0,
            particles: particles.into_iter().map(|(_, p, k, _)| (p, k)).collect(),
            cells,
            h,
            iso,
            bounds: bounds.padded(h),
            spray: Vec::new(),
            spray_rule: None,
        }
    }

    /// Gives the particles their velocities (in input order), which makes the density a
    /// [`Flow`] too.
    pub fn with_velocities(mut self, velocities: &[Vec3]) -> Self {
        assert_eq!(
            velocities.len(),
            self.order.len(),
            "one velocity per particle"
        );
        self.velocities = self.order.iter().map(|&i| velocities[i as usize]).collect();
        self
    }

    /// Whether the particles carry velocities.
    pub fn has_velocities(&self) -> bool {
        !self.velocities.is_empty()
    }

    /// G at `p`.
    pub fn density(&self, p: Vec3) -> f32 {
        self.density_and_gradient(p).0
    }

    /// G and ∇G at `p` in one pass over the neighbours:
    /// ∇W = −6 (1 − q²)² (p − p_i) / h_i².
    pub fn density_and_gradient(&self, p: Vec3) -> (f32, Vec3) {
        let cell = (p / self.h).floor().as_ivec3();
        let (mut g, mut grad) = (0.0, Vec3::ZERO);
        for d in AROUND {
            if let Some(&(start, end)) = self.cells.get(&(cell + d)) {
                let run = start as usize..end as usize;
                for (&(q, inv_h2), &v) in self.particles[run.clone()].iter().zip(&self.volumes[run])
                {
                    let r = p - q;
                    let s = 1.0 - r.length_squared() * inv_h2;
                    if s > 0.0 {
                        g += v * s * s * s;
                        grad -= r * (6.0 * v * s * s * inv_h2);
                    }
                }
            }
        }
        (g, grad)
    }

    /// Each particle's kernel divided by its own density in units of the fluid's at rest
    /// (SPH's volume m/ρ_i, [`rest_density`] for `smoothing_length`): in the bulk of a
    /// fluid at rest nothing changes, while thin sheets and spray, whose own density is
    /// low, keep a surface. No more than [`Density::droplet_volume`]: a lone particle
    /// is then a droplet holding the (2r)³ of liquid it stands for, not three times it
    /// (unbounded, its surface sat at 1.57 r, and a splash's spray added 1–2 % to the
    /// liquid's volume on the dam break's impact frames).
    pub fn normalized(mut self, smoothing_length: f32) -> Self {
        let (rest, most) = (
            rest_density(smoothing_length),
            self.droplet_volume(smoothing_length),
        );
        let volume = |g: f32| (rest / g.max(1e-6)).min(most);
        // A fluid's neighbourhood (27 cells of the support) holds 27·l³ particles at
        // rest; many times that is particles piled on each other (a copied piece, a
        // broken export), whose pairs would cost their number squared.
        let crowd = CROWD_OVER_REST * 27.0 * smoothing_length.powi(3);
        let (link2, most) = self.spray_rule.map_or((-1.0, 0), |(l, m)| (l * l, m));
        let sums: Vec<(f32, bool)> = self.per_cell(|cell, runs| {
            if runs.iter().map(ExactSizeIterator::len).sum::<usize>() as f32 > crowd {
                return self
                    .crowded_sums(cell, runs)
                    .into_iter()
                    .map(|g| (volume(g), true))
                    .collect();
            }
            // Each sum in the same order as `density`'s; the neighbours within the
            // spray's link counted on the way (itself included).
            cell.map(|i| {
                let p = self.particles[i].0;
                let (mut g, mut linked) = (0.0f32, 0usize);
                for run in runs {
                    for &(q, inv_h2) in &self.particles[run.clone()] {
                        let d2 = (p - q).length_squared();
                        linked += usize::from(d2 <= link2);
                        let s = 1.0 - d2 * inv_h2;
                        if s > 0.0 {
                            g += s * s * s;
                        }
                    }
                }
                (volume(g), linked > most)
            })
            .collect()
        });
        let crowded: Vec<bool>;
        (self.volumes, crowded) = sums.into_iter().unzip();
        if self.spray_rule.is_some() {
            self.spray = self.walk_spray(&crowded, link2, most);
        }
        self
    }

    /// Each own-density sum of the particles `cell` in a crowded neighbourhood `runs`,
    /// with the particles gathered in cubes of an eighth of the support (those of one
    /// support, at their centroid, counted as many as they are) on both sides of the sum:
    /// at most 8³ × 24³ terms a cell, however many particles; exact where they coincide.
    fn crowded_sums(&self, cell: Range<usize>, runs: &[Range<usize>]) -> Vec<f32> {
        let step = self.h / CROWD_CUBES;
        type Cubes = HashMap<(IVec3, u32), (Vec3, f32)>;
        let gather = |range: &mut dyn Iterator<Item = usize>| -> Cubes {
            let mut cubes: Cubes = HashMap::new();
            for i in range {
                let (p, inv_h2) = self.particles[i];
                let key = ((p / step).floor().as_ivec3(), inv_h2.to_bits());
                let (sum, n) = cubes.entry(key).or_insert((Vec3::ZERO, 0.0));
                *sum += p;
                *n += 1.0;
            }
            cubes
        };
        let around = gather(&mut runs.iter().flat_map(Range::clone));
        let own = gather(&mut cell.clone());
        let sums: HashMap<(IVec3, u32), f32> = own
            .iter()
            .map(|(&key, &(sum, n))| {
                let p = sum / n;
                let g = around
                    .values()
                    .map(|&(sum, m)| {
                        let s = 1.0 - (p - sum / m).length_squared() * f32::from_bits(key.1);
                        if s > 0.0 {
                            m * s * s * s
                        } else {
                            0.0
                        }
                    })
                    .sum();
                (key, g)
            })
            .collect();
        cell.map(|i| {
            let (p, inv_h2) = self.particles[i];
            sums[&((p / step).floor().as_ivec3(), inv_h2.to_bits())]
        })
        .collect()
    }

    /// Marks the spray when the density is [`Density::normalized`]: the members of
    /// clusters of at most `most` particles, a cluster being the particles linked by
    /// chains of steps of at most `link` (world units, no more than the support), with
    /// no particle of another such cluster within the support. Such
    /// particles are then rasterized apart from the rest and the two densities united
    /// ([`DensityGrid::union`]): summed, a drop a few radii off the liquid is joined to
    /// it by the kernels' tails.
    pub fn finding_spray(mut self, link: f32, most: usize) -> Self {
        self.spray_rule = Some((link.min(self.h), most));
        self
    }

    /// Whether some particles are spray ([`Density::finding_spray`]).
    pub fn has_spray(&self) -> bool {
        self.spray.iter().any(|&s| s)
    }

    /// The spray particles' positions.
    pub fn spray_positions(&self) -> Vec<Vec3> {
        let mut out: Vec<(u32, Vec3)> = (self.spray.iter().zip(&self.particles).zip(&self.order))
            .filter(|((&s, _), _)| s)
            .map(|((_, &(p, _)), &i)| (i, p))
            .collect();
        out.sort_unstable_by_key(|&(i, _)| i);
        out.into_iter().map(|(_, p)| p).collect()
    }

    /// Whether particle `i` (in `particles`' order) is spray.
    fn is_spray(&self, i: usize) -> bool {
        self.spray.get(i).copied().unwrap_or(false)
    }

    /// The spray among particles of which `crowded` (in `particles`' order) have more
    /// than `most` others within `link` (squared: `link2`): those and every particle
    /// linked to them are not; the few left are walked cluster by cluster. A small
    /// cluster is spray when no particle of another small cluster lies within the
    /// support of it: a drop off the liquid, not a sheet or a mist spread thin, whose
    /// particles the sum must join.
    fn walk_spray(&self, crowded: &[bool], link2: f32, most: usize) -> Vec<bool> {
        const UNSEEN: u32 = u32::MAX;
        const WALKED: u32 = u32::MAX - 1;
        const BULK: u32 = u32::MAX - 2;
        // Each particle's small cluster, else one of the marks above.
        let mut state: Vec<u32> = crowded
            .iter()
            .map(|&c| if c { BULK } else { UNSEEN })
            .collect();
        let key = |p: Vec3| (p / self.h).floor().as_ivec3();
        // The particles within `reach2` of `p`, by index.
        let around = |p: Vec3, reach2: f32| {
            AROUND
                .iter()
                .filter_map(move |&d| self.cells.get(&(key(p) + d)))
                .flat_map(move |&(a, b)| {
                    let run = a as usize..b as usize;
                    run.clone()
                        .zip(&self.particles[run])
                        .filter(move |(_, &(q, _))| (q - p).length_squared() <= reach2)
                        .map(|(j, _)| j)
                })
        };
        let mut clusters: Vec<Vec<usize>> = Vec::new();
        let mut cluster = Vec::new();
        for start in 0..self.particles.len() {
            if state[start] != UNSEEN {
                continue;
            }
            state[start] = WALKED;
            cluster.clear();
            cluster.push(start);
            let (mut next, mut bulk) = (0, false);
            while next < cluster.len() && !bulk {
                let p = self.particles[cluster[next]].0;
                next += 1;
                for j in around(p, link2) {
                    bulk |= state[j] == BULK;
                    if state[j] == UNSEEN {
                        state[j] = WALKED;
                        cluster.push(j);
                    }
                }
                bulk |= cluster.len() > most;
            }
            let end = match bulk {
                true => BULK,
                false => clusters.len() as u32,
            };
            for &i in &cluster {
                state[i] = end;
            }
            if !bulk {
                clusters.push(cluster.clone());
            }
        }
        let h2 = self.h * self.h;
        let mut spray = vec![false; self.particles.len()];
        for (id, members) in clusters.iter().enumerate() {
            let alone = members.iter().all(|&i| {
                around(self.particles[i].0, h2).all(|j| state[j] == BULK || state[j] == id as u32)
            });
            if alone {
                for &i in members {
                    spray[i] = true;
                }
            }
        }
        spray
    }

    /// Averages the velocity over the particles within `radii` particle radii (at most
    /// the density's support, 2·`smoothing_length` radii) instead of the density's whole
    /// support: see [`VELOCITY_SUPPORT_RADII`].
    pub fn velocity_within(mut self, radii: f32, smoothing_length: f32) -> Self {
        self.velocity_support = (radii / (2.0 * smoothing_length)).min(1.0);
        self
    }

    /// 1/(support ratio)², the factor from the density kernel's q² to the velocity's.
    fn velocity_q2_scale(&self) -> f32 {
        self.velocity_support.powi(-2)
    }

    /// The kernel weight that makes a lone particle a sphere of the volume it stands for,
    /// (2r)³ (radius (6/π)^⅓ r ≈ 1.24 r; splashsurf's droplets are 1.18 r), at this
    /// density's iso, with the support 2·`smoothing_length`·r.
    pub fn droplet_volume(&self, smoothing_length: f32) -> f32 {
        let radius = (6.0 / std::f32::consts::PI).cbrt();
        self.iso / kernel(radius / (2.0 * smoothing_length))
    }

    /// `f(cell, runs)` for every cell, its particles `cell` (a range of `particles`) given
    /// the runs of the (up to 27) occupied cells around it in [`AROUND`]'s order, one
    /// value a particle, in `particles`' order: computed cell by cell in parallel, so that
    /// the neighbour cells are looked up once per cell, not once per particle.
    fn per_cell<T: Send>(
        &self,
        f: impl Fn(Range<usize>, &[Range<usize>]) -> Vec<T> + Sync,
    ) -> Vec<T> {
        let mut cells: Vec<(IVec3, u32, u32)> =
            self.cells.iter().map(|(&c, &(a, b))| (c, a, b)).collect();
        // By run, so that the results come out in `particles`' order.
        cells.sort_unstable_by_key(|&(_, start, _)| start);
        cells
            .par_iter()
            .flat_map_iter(|&(cell, start, end)| {
                let runs: Vec<Range<usize>> = AROUND
                    .iter()
                    .filter_map(|&d| {
                        let &(a, b) = self.cells.get(&(cell + d))?;
                        Some(a as usize..b as usize)
                    })
                    .collect();
                f(start as usize..end as usize, &runs)
            })
            .collect()
    }
}

impl Density {
    /// The density sampled on voxels of `dx` as a VDB fog volume named `density`
    /// (background 0, active where G > 0), for inspection next to the skin.
    pub fn to_fog_volume(&self, dx: f32) -> GridData {
        let leaf = 8.0 * dx;
        let mut coords: HashSet<IVec3> = HashSet::new();
        for &(p, _) in &self.particles {
            let lo = ((p - Vec3::splat(self.h)) / leaf).floor().as_ivec3();
            let hi = ((p + Vec3::splat(self.h)) / leaf).floor().as_ivec3();
            for x in lo.x..=hi.x {
                for y in lo.y..=hi.y {
                    for z in lo.z..=hi.z {
                        coords.insert(IVec3::new(x, y, z));
                    }
                }
            }
        }
        let mut coords: Vec<IVec3> = coords.into_iter().collect();
        coords.sort_unstable_by_key(|c| c.to_array());
        let leaves: Vec<(IVec3, Vec<f32>, [u64; MASK_WORDS])> = coords
            .par_iter()
            .map(|&c| {
                let origin = c * 8;
                let mut mask = [0u64; MASK_WORDS];
                let values: Vec<f32> = (0..LEAF_VOXELS)
                    .map(|offset| {
                        let l = offset_coords(offset);
                        let g = self.density((origin + l).as_vec3() * dx);
                        if g > 0.0 {
                            mask[offset >> 6] |= 1 << (offset & 63);
                        }
                        g
                    })
                    .collect();
                (origin, values, mask)
            })
            .filter(|(_, _, mask)| mask.iter().any(|&w| w != 0))
            .collect();
        let transform = Transform::uniform(f64::from(dx), [0.0; 3]);
        let mut data = GridData::empty("density", GridClass::FogVolume, 0.0, transform);
        for (origin, values, mask) in leaves {
            data.push_leaf(origin.to_array(), &values, mask);
        }
        data
    }
}

impl Density {
    /// Per-particle quantities (`components` values a particle, in input order) at each
    /// of `points`, from the particles the density's kernel reaches there, weighted as
    /// the density sums them (each particle's kernel times its volume). Linear least
    /// squares about their weighted centroid, so that a linear field is kept where the
    /// neighbourhood is one-sided (at the surface, where a weighted mean, Shepard's,
    /// leans inward by half a particle radius), limited to the values around (a flag
    /// stays within 0–1) and Shepard's where the neighbours span no volume (a lone
    /// droplet, a sheet's normal). 0 where no particle reaches. Each point's
    /// neighbourhood is walked once for all the `fields`, `(values, components)`.
    pub fn interpolate(&self, points: &[Vec3], fields: &[(&[f32], usize)]) -> Vec<Vec<f32>> {
        for &(values, components) in fields {
            assert_eq!(
                values.len(),
                self.order.len() * components,
                "a value per particle"
            );
        }
        let width: usize = fields.iter().map(|f| f.1).sum();
        let mut out = vec![0.0f32; points.len() * width];
        if width > 0 {
            out.par_chunks_mut(width)
                .zip(points.par_iter())
                .for_each_init(Vec::new, |near, (out, &p)| {
                    self.interpolate_at(p, fields, near, out)
                });
        }
        // Point-major rows split into one array per field.
        let mut offset = 0;
        fields
            .iter()
            .map(|&(_, c)| {
                let field: Vec<f32> = out
                    .par_chunks(width)
                    .flat_map_iter(|row| row[offset..offset + c].iter().copied())
                    .collect();
                offset += c;
                field
            })
            .collect()
    }

    /// [`Density::interpolate`] at `p`, into `out` (the fields' components side by side);
    /// `near` is scratch for the neighbours (index, weight).
    fn interpolate_at(
        &self,
        p: Vec3,
        fields: &[(&[f32], usize)],
        near: &mut Vec<(u32, f32)>,
        out: &mut [f32],
    ) {
        use glam::{DMat3, DVec3};
        near.clear();
        let cell = (p / self.h).floor().as_ivec3();
        // Moments about p (small offsets: no cancellation).
        let (mut w_sum, mut x_sum) = (0.0f64, DVec3::ZERO);
        let mut xx = [0.0f64; 6];
        for d in AROUND {
            let Some(&(start, end)) = self.cells.get(&(cell + d)) else {
                continue;
            };
            for i in start as usize..end as usize {
                let (q, inv_h2) = self.particles[i];
                let s = 1.0 - (p - q).length_squared() * inv_h2;
                if s <= 0.0 {
                    continue;
                }
                let w = self.volumes[i] * s * s * s;
                let x = (q - p).as_dvec3();
                let wd = f64::from(w);
                w_sum += wd;
                x_sum += wd * x;
                // The symmetric second moment, its six entries.
                let wx = wd * x;
                xx[0] += wx.x * x.x;
                xx[1] += wx.x * x.y;
                xx[2] += wx.x * x.z;
                xx[3] += wx.y * x.y;
                xx[4] += wx.y * x.z;
                xx[5] += wx.z * x.z;
                near.push((i as u32, w));
            }
        }
        if w_sum <= 0.0 {
            return;
        }
        let centroid = x_sum / w_sum;
        let [a, b, c, d, e, f] = xx.map(|m| m / w_sum);
        let spread = DMat3::from_cols_array(&[a, b, c, b, d, e, c, e, f])
            - DMat3::from_cols(
                centroid * centroid.x,
                centroid * centroid.y,
                centroid * centroid.z,
            );
        // A neighbourhood that spans no volume in some direction has no gradient there:
        // regularized by a tenth of the (largest) support, squared.
        let eps = (0.1 * f64::from(self.h)).powi(2);
        let inverse = (spread + DMat3::IDENTITY * eps).inverse();
        let mut column = 0;
        for &(values, components) in fields {
            for k in 0..components {
                let (mut a_sum, mut xa) = (0.0f64, DVec3::ZERO);
                let mut range = (f32::INFINITY, f32::NEG_INFINITY);
                for &(i, w) in near.iter() {
                    let a = values[self.order[i as usize] as usize * components + k];
                    let wa = f64::from(w) * f64::from(a);
                    a_sum += wa;
                    xa += wa * (self.particles[i as usize].0 - p).as_dvec3();
                    range = (range.0.min(a), range.1.max(a));
                }
                let mean = a_sum / w_sum;
                let covariance = xa / w_sum - centroid * mean;
                let gradient = inverse * covariance;
                // p is the origin of the offsets: p − centroid = −centroid.
                let value = mean - gradient.dot(centroid);
                out[column] = (value as f32).clamp(range.0, range.1);
                column += 1;
            }
        }
    }
}

/// The particles' velocity at a point: their mean weighted by their kernels (Shepard),
/// the density's own, each extended by its gradient when fitted; zero where no particle
/// reaches, or when the particles carry no velocity.
impl Flow for Density {
    fn velocity(&self, p: Vec3) -> Vec3 {
        if self.velocities.is_empty() {
            return Vec3::ZERO;
        }
        let cell = (p / self.h).floor().as_ivec3();
        let scale = self.velocity_q2_scale();
        let (mut sum, mut weight) = (Vec3::ZERO, 0.0f32);
        for d in AROUND {
            if let Some(&(start, end)) = self.cells.get(&(cell + d)) {
                for i in start as usize..end as usize {
                    let (q, inv_h2) = self.particles[i];
                    let s = 1.0 - (p - q).length_squared() * inv_h2 * scale;
                    if s > 0.0 {
                        let w = self.volumes[i] * s * s * s;
                        sum += w * self.velocities[i];
                        weight += w;
                    }
                }
            }
        }
        if weight > MIN_VELOCITY_WEIGHT {
            sum / weight
        } else {
            Vec3::ZERO
        }
    }
}

impl Target for Density {
    /// First-order distance to the iso-density surface, (iso − G)/|∇G|, capped at h where
    /// the density fades.
    fn distance(&self, p: Vec3) -> f32 {
        let (g, grad) = self.density_and_gradient(p);
        let value = self.iso - g;
        // Where the density fades its gradient does too: cap instead of dividing by ~0.
        let norm = grad.length().max(value.abs() / self.h).max(1e-12);
        (value / norm).clamp(-self.h, self.h)
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_matches_finite_differences_and_lone_particle_sits_at_its_radius() {
        let points = vec![
            Vec3::ZERO,
            Vec3::new(0.07, 0.02, -0.03),
            Vec3::new(-0.05, 0.04, 0.01),
        ];
        let h = 0.1;
        let density = Density::new(points, h, iso_for_radius(0.05, h));
        let p = Vec3::new(0.02, 0.03, 0.01);
        let (_, grad) = density.density_and_gradient(p);
        let e = 1e-4;
        let fd = Vec3::new(
            density.density(p + Vec3::X * e) - density.density(p - Vec3::X * e),
            density.density(p + Vec3::Y * e) - density.density(p - Vec3::Y * e),
            density.density(p + Vec3::Z * e) - density.density(p - Vec3::Z * e),
        ) / (2.0 * e);
        assert!(
            (grad - fd).length() < 1e-2 * grad.length(),
            "{grad} vs {fd}"
        );

        let lone = Density::new(vec![Vec3::ZERO], h, iso_for_radius(0.05, h));
        assert!(lone.distance(Vec3::new(0.05, 0.0, 0.0)).abs() < 1e-6);
        assert!(lone.distance(Vec3::ZERO) < 0.0 && lone.distance(Vec3::X * 0.07) > 0.0);
    }

    #[test]
    fn each_particle_sits_at_its_own_radius() {
        let (small, large) = (0.05, 0.12);
        let at = [Vec3::ZERO, Vec3::X];
        let density = Density::with_supports(
            at.to_vec(),
            vec![2.0 * small, 2.0 * large],
            iso_for_radius(1.0, 2.0),
        );
        for (centre, radius) in at.into_iter().zip([small, large]) {
            for dir in [Vec3::X, Vec3::Y, -Vec3::Z] {
                let d = density.distance(centre + dir * radius);
                assert!(d.abs() < 1e-5, "radius {radius}: {d}");
            }
        }
        // The gradient with mixed supports still matches finite differences.
        let p = Vec3::new(0.9, 0.05, 0.0);
        let (_, grad) = density.density_and_gradient(p);
        let e = 1e-3;
        let fd = (density.density(p + Vec3::X * e) - density.density(p - Vec3::X * e)) / (2.0 * e);
        assert!(
            (grad.x - fd).abs() < 1e-2 * grad.length(),
            "{} vs {fd}",
            grad.x
        );
    }

    /// Particles of radius 1 on a lattice of spacing 2, `n` along each axis from `at`.
    fn lattice(n: [i32; 3], at: Vec3) -> Vec<Vec3> {
        let mut out = Vec::new();
        for i in 0..n[0] {
            for j in 0..n[1] {
                for k in 0..n[2] {
                    out.push(at + 2.0 * Vec3::new(i as f32, j as f32, k as f32));
                }
            }
        }
        out
    }

    /// Spray is the clusters of at most 16 particles past the link (3.25 radii) from any
    /// other, with no other such cluster within the support (4 radii): a clump of three
    /// 3.5 radii over a pool and a line of 16 are; a particle 3 radii off the pool, a
    /// line of 17 and two particles 3.5 radii apart (a mist, a sheet spread thin) are
    /// not, nor the pool.
    #[test]
    fn spray_is_the_small_clusters_past_the_link() {
        let mut points = lattice([8, 8, 4], Vec3::ZERO);
        let top = Vec3::new(8.0, 8.0, 6.0);
        let clump = [0.0, 0.4, 0.8].map(|x| top + Vec3::new(x, 0.3 * x, 3.5 + 0.2 * x));
        let linked = Vec3::new(-3.0, 4.0, 2.0);
        let sixteen = lattice([16, 1, 1], Vec3::new(0.0, 40.0, 0.0));
        let seventeen = lattice([17, 1, 1], Vec3::new(0.0, 60.0, 0.0));
        points.extend(clump);
        points.push(linked);
        points.extend(&sixteen);
        points.extend(&seventeen);
        points.extend([Vec3::new(0.0, 80.0, 0.0), Vec3::new(3.5, 80.0, 0.0)]);
        let density = Density::new(points.clone(), 4.0, fluid_iso(2.0))
            .finding_spray(3.25, SPRAY_MOST)
            .normalized(2.0);
        let expected: Vec<Vec3> = clump.iter().chain(&sixteen).copied().collect();
        assert_eq!(density.spray_positions(), expected);
        // Not asked, none.
        let plain = Density::new(points, 4.0, fluid_iso(2.0)).normalized(2.0);
        assert!(!plain.has_spray());
    }
}
