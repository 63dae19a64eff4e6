//! What an artist sees in a liquid's surface, measured (issue 49): particle-scale bumps,
//! droplets kept as pieces, and how thick single-layer sheets come out. Used by
//! `activeskin bench --particles` on every tool's meshes alike and by the tests.

use glam::{IVec3, Vec3};
use hashbrown::HashMap;
use rayon::prelude::*;

use crate::mesh::Mesh;

/// The scale bumps are measured over, in particle radii: a wave turns little over
/// 3 r; particle-scale bumps turn a lot.
pub const BUMP_REACH_RADII: f32 = 3.0;

/// Points bucketed in cubes of side `cell`, for neighbour queries within `cell`.
struct Buckets {
    cell: f32,
    of: HashMap<IVec3, Vec<u32>>,
}

impl Buckets {
    fn new(points: impl Iterator<Item = (u32, Vec3)>, cell: f32) -> Self {
        let mut of: HashMap<IVec3, Vec<u32>> = HashMap::new();
        for (i, p) in points {
            of.entry((p / cell).floor().as_ivec3()).or_default().push(i);
        }
        Buckets { cell, of }
    }

    /// Every point in the 27 cubes around `p` (a superset of those within `cell`).
    fn around(&self, p: Vec3) -> impl Iterator<Item = u32> + '_ {
        let c = (p / self.cell).floor().as_ivec3();
        (0..27).flat_map(move |n| {
            let d = IVec3::new(n / 9 - 1, n / 3 % 3 - 1, n % 3 - 1);
            self.of.get(&(c + d)).into_iter().flatten().copied()
        })
    }
}

/// The least a piece must enclose to count, in particle volumes (2r)³: a lone particle
/// encloses about one; smoothing that shrinks a droplet to a speck of no volume (as
/// splashsurf's does) leaves a piece no one sees.
pub const PIECE_PARTICLE_VOLUMES: f64 = 0.1;

/// Connected pieces of a mesh that enclose liquid (droplets, sheets torn off, the body):
/// those whose outward volume is at least [`PIECE_PARTICLE_VOLUMES`] of a particle's
/// (2·`radius`)³. Specks of no volume and cavities (inward pieces, bubbles) not counted.
pub fn pieces(mesh: &Mesh, radius: f32) -> usize {
    let labels = crate::mesh::piece_labels(mesh);
    let mut volumes: HashMap<u32, f64> = HashMap::new();
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize].as_dvec3());
        *volumes.entry(labels[t[0] as usize]).or_default() += a.dot(b.cross(c)) / 6.0;
    }
    let least = PIECE_PARTICLE_VOLUMES * (2.0 * f64::from(radius)).powi(3);
    volumes.values().filter(|&&v| v >= least).count()
}

/// Particle-scale bumps, in degrees: on the largest connected piece of `mesh`, the mean
/// angle between each vertex's area-weighted normal and the mean of those normals over
/// the vertices within [`BUMP_REACH_RADII`]·`radius` of it. A plane or a sphere large
/// against that reach scores near 0; a surface pebbled by its particles does not.
pub fn bumps(mesh: &Mesh, radius: f32) -> f64 {
    bumps_where(mesh, radius, |_| true)
}

/// [`bumps`] averaged over the vertices of the largest piece where `keep` holds (their
/// neighbourhoods taken from the whole piece): a region of a surface, away from its
/// edges.
pub fn bumps_where(mesh: &Mesh, radius: f32, keep: impl Fn(Vec3) -> bool + Sync) -> f64 {
    if mesh.triangles.is_empty() {
        return 0.0;
    }
    let mut normals = vec![Vec3::ZERO; mesh.positions.len()];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        // Twice the area along the normal: area-weighted.
        let n = (b - a).cross(c - a);
        for &i in t {
            normals[i as usize] += n;
        }
    }
    let labels = crate::mesh::piece_labels(mesh);
    let mut sizes: HashMap<u32, usize> = HashMap::new();
    for t in &mesh.triangles {
        *sizes.entry(labels[t[0] as usize]).or_default() += 1;
    }
    let largest = sizes
        .iter()
        .max_by_key(|(label, n)| (**n, std::cmp::Reverse(**label)))
        .map(|(label, _)| *label)
        .unwrap_or_default();
    let normals: Vec<Vec3> = normals.iter().map(|n| n.normalize_or_zero()).collect();
    let on: Vec<u32> = (0..mesh.positions.len() as u32)
        .filter(|&i| labels[i as usize] == largest && normals[i as usize] != Vec3::ZERO)
        .collect();
    let reach = BUMP_REACH_RADII * radius;
    let buckets = Buckets::new(on.iter().map(|&i| (i, mesh.positions[i as usize])), reach);
    let (sum, count) = on
        .par_iter()
        .filter(|&&i| keep(mesh.positions[i as usize]))
        .map(|&i| {
            let p = mesh.positions[i as usize];
            let mean: Vec3 = buckets
                .around(p)
                .filter(|&j| mesh.positions[j as usize].distance_squared(p) <= reach * reach)
                .map(|j| normals[j as usize])
                .sum();
            let cos = normals[i as usize]
                .dot(mean.normalize_or_zero())
                .clamp(-1.0, 1.0);
            (f64::from(cos).acos().to_degrees(), 1usize)
        })
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    sum / count.max(1) as f64
}

/// How much the facets of a flat surface tilt, in degrees: the area-weighted mean angle
/// between `up` and the normals of the triangles of `mesh` facing within 45° of it whose
/// centroids pass `keep` (the middle of a pool's top, say). A still liquid's top is a
/// plane: what tilts there is noise the mesher or the particles left.
pub fn facet_tilt(mesh: &Mesh, up: Vec3, keep: impl Fn(Vec3) -> bool) -> f64 {
    let (mut sum, mut area) = (0.0f64, 0.0f64);
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a);
        let twice = f64::from(n.length());
        let cos = f64::from(n.dot(up)) / twice.max(f64::MIN_POSITIVE);
        if twice > 0.0 && cos > std::f64::consts::FRAC_1_SQRT_2 && keep((a + b + c) / 3.0) {
            sum += twice * cos.min(1.0).acos().to_degrees();
            area += twice;
        }
    }
    sum / area.max(f64::MIN_POSITIVE)
}

/// The particles of `cloud` (radius `radius`, 2r apart) that lie in a sheet one particle
/// thick: at least four neighbours within 3r, all within a tenth of the spacing of
/// a plane through the particle, and none stacked on it (within 3r, every neighbour's
/// offset from the plane under 0.4r). Their signed distances to a surface, doubled and
/// negated, are the sheet's thickness there.
pub fn single_layer(cloud: &[Vec3], radius: f32) -> Vec<bool> {
    let reach = 3.0 * radius;
    let buckets = Buckets::new(cloud.iter().enumerate().map(|(i, &p)| (i as u32, p)), reach);
    cloud
        .par_iter()
        .map(|&p| {
            let near: Vec<Vec3> = buckets
                .around(p)
                .map(|j| cloud[j as usize] - p)
                .filter(|d| d.length_squared() <= reach * reach && *d != Vec3::ZERO)
                .collect();
            if near.len() < 4 {
                return false;
            }
            // The plane through p that the neighbours lie closest to: the least
            // eigenvector of their second moment about p.
            let mut m = glam::Mat3::ZERO;
            for d in &near {
                m += glam::Mat3::from_cols(*d * d.x, *d * d.y, *d * d.z);
            }
            let normal = least_eigenvector(m);
            near.iter().all(|d| d.dot(normal).abs() < 0.4 * radius)
        })
        .collect()
}

/// The eigenvector of the symmetric `m`'s smallest eigenvalue, by inverse power
/// iteration on m + ε (well enough for a plane fit).
fn least_eigenvector(m: glam::Mat3) -> Vec3 {
    let scale = m.col(0).x + m.col(1).y + m.col(2).z;
    let shifted = m + glam::Mat3::from_diagonal(Vec3::splat(1e-4 * scale.max(f32::MIN_POSITIVE)));
    let inverse = shifted.inverse();
    let mut v = Vec3::new(0.577, 0.577, 0.577);
    for _ in 0..16 {
        let next = (inverse * v).normalize_or_zero();
        if next == Vec3::ZERO || !next.is_finite() {
            break;
        }
        v = next;
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::polygonize::mesh_vdb;
    use crate::target::{sample, Sphere};

    #[test]
    fn a_large_sphere_has_few_bumps_and_one_piece() {
        let dx = 0.02;
        let sphere = Sphere {
            center: Vec3::splat(1.0),
            radius: 0.6,
        };
        let mesh = mesh_vdb(sample::level_set(&sphere, dx, 3.0), |v| v);
        assert_eq!(pieces(&mesh, dx), 1);
        // A smooth surface turns symmetrically about each vertex: what is left is
        // marching cubes' own facets (measured 0.70°).
        let b = bumps(&mesh, dx);
        assert!(b < 1.0, "{b}");
        // The same sphere pebbled by bumps of a voxel's wavelength turns far more.
        let mut rough = mesh.clone();
        for p in &mut rough.positions {
            let d = *p - sphere.center;
            let wave = (p.x / dx * 1.7).sin() * (p.y / dx * 1.3).sin() * (p.z / dx * 1.1).sin();
            *p = sphere.center + d * (1.0 + 0.4 * dx / sphere.radius * wave);
        }
        let r = bumps(&rough, dx);
        assert!(r > 3.0 * b, "{r} against {b}");
    }

    #[test]
    fn a_plane_tilts_as_it_is_turned_and_its_kept_part_only_counts() {
        // A 10 × 10 grid of squares in the xz plane, turned 3° about z.
        let mut mesh = Mesh::default();
        let turn = glam::Quat::from_rotation_z(3f32.to_radians());
        for i in 0..11 {
            for k in 0..11 {
                mesh.positions
                    .push(turn * Vec3::new(i as f32, 0.0, k as f32));
            }
        }
        for i in 0..10u32 {
            for k in 0..10u32 {
                let v = |a: u32, b: u32| a * 11 + b;
                mesh.triangles.push([v(i, k), v(i, k + 1), v(i + 1, k)]);
                mesh.triangles
                    .push([v(i + 1, k), v(i, k + 1), v(i + 1, k + 1)]);
            }
        }
        let tilt = facet_tilt(&mesh, Vec3::Y, |_| true);
        assert!((tilt - 3.0).abs() < 1e-3, "{tilt}");
        // A part turned further (its two halves' triangles lifted at one end) counts
        // only when kept.
        let first_row = |c: Vec3| c.z < 1.0;
        for p in mesh.positions.iter_mut().filter(|p| p.z < 0.5) {
            p.y += 0.5;
        }
        let lifted = facet_tilt(&mesh, Vec3::Y, first_row);
        let rest = facet_tilt(&mesh, Vec3::Y, |c| c.z > 1.0);
        assert!(lifted > 20.0, "{lifted}");
        assert!((rest - 3.0).abs() < 1e-3, "{rest}");
        // Faces turned away from up (a wall) are not a top's.
        assert_eq!(facet_tilt(&mesh, Vec3::X, |_| true), 0.0);
    }

    #[test]
    fn a_sheet_of_particles_is_single_layer_and_a_slab_is_not() {
        let r = 0.5;
        let mut sheet = Vec::new();
        let mut slab = Vec::new();
        for i in 0..12 {
            for j in 0..12 {
                let p = Vec3::new(i as f32, j as f32, 0.0) * 2.0 * r;
                sheet.push(p);
                slab.push(p);
                slab.push(p + Vec3::Z * 2.0 * r);
            }
        }
        let s = single_layer(&sheet, r);
        // Every particle but the corners' (three neighbours within 3r... they have 3).
        assert!(s.iter().filter(|&&b| b).count() >= 140, "{:?}", s);
        assert!(single_layer(&slab, r).iter().all(|&b| !b));
    }
}
