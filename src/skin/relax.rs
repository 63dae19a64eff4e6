//! The written mesh's triangles evened along the skin ([`crate::mesh::relax_on_surface`]):
//! a smoothed skin should not show marching cubes' facets either. Read from a wide halo
//! of the block each vertex was made in (the polygonizer makes them block by block, so
//! a thread gathers each block about once a step).

use glam::{IVec3, Vec3};

use super::Skin;
use crate::grid::{block_of, IndexToWorld, Potential, SparseGrid, WideHalo, BLOCK_DIM, WIDE_DIM};
use crate::mesh::Surface;

/// Steps of evening, and how far (voxels) a vertex may move in all: half a voxel keeps
/// it within the cell it was made in or the next.
const STEPS: usize = 8;
const REACH: f32 = 0.5;

impl<P: Potential> Skin<P> {
    /// Evens the mesh's triangles without moving the surface.
    pub(super) fn relax_mesh(&mut self) {
        let surface = OnGrid {
            grid: &self.grid,
            xf: self.xf,
        };
        crate::mesh::relax_on_surface(&mut self.mesh, (STEPS, REACH * self.xf.dx), &surface);
    }
}

/// The potential as an implicit surface: trilinear between nodes, its normals from the
/// central differences at a cell's corners, interpolated (as the polygonizer's).
struct OnGrid<'a, P> {
    grid: &'a SparseGrid<P>,
    xf: IndexToWorld,
}

/// A thread's copy of the nodes around one block.
struct Probe {
    halo: Box<WideHalo>,
    block: Option<IVec3>,
}

/// A point's cell (its lower node, grid coordinates) and its place in it.
struct Cell {
    lower: IVec3,
    t: Vec3,
}

impl<P: Potential> OnGrid<'_, P> {
    fn cell(&self, p: Vec3) -> Cell {
        let u = (p - self.xf.origin) / self.xf.dx;
        Cell {
            lower: u.floor().as_ivec3(),
            t: u - u.floor(),
        }
    }

    /// Makes `probe` hold the block `home` lies in, with two nodes around.
    fn gather(&self, probe: &mut Probe, home: Vec3) {
        let coord = block_of(self.cell(home).lower);
        if probe.block != Some(coord) {
            probe.block = self.grid.find(coord).map(|id| {
                probe.halo.gather(self.grid, self.grid.block(id));
                coord
            });
        }
    }

    /// The potential at node `ijk`: from the probe's halo where it reaches (a vertex
    /// moves half a voxel at most, so nearly always), from the grid otherwise.
    fn node(&self, probe: &Probe, ijk: IVec3) -> f32 {
        if let Some(coord) = probe.block {
            let l = ijk - coord * BLOCK_DIM;
            if l.min_element() >= -2 && l.max_element() < BLOCK_DIM + 2 {
                return probe.halo.at(l.x, l.y, l.z);
            }
        }
        self.grid.value(ijk)
    }

    /// The potential at the eight corners of the cell with lower node `lower` ([`corner`]'s
    /// order): one reach test and fixed strides where the probe's halo holds the cell,
    /// as it nearly always does (each evening step reads every vertex's cell).
    fn corners(&self, probe: &Probe, lower: IVec3) -> [f32; 8] {
        if let Some(coord) = probe.block {
            let l = lower - coord * BLOCK_DIM;
            if l.min_element() >= -2 && l.max_element() < BLOCK_DIM + 1 {
                let (i, s) = (WideHalo::index(l.x, l.y, l.z), WIDE_DIM);
                let v = &probe.halo.values;
                let plane = i + s * s;
                return [
                    v[i],
                    v[i + 1],
                    v[i + s],
                    v[i + s + 1],
                    v[plane],
                    v[plane + 1],
                    v[plane + s],
                    v[plane + s + 1],
                ];
            }
        }
        std::array::from_fn(|n| self.node(probe, lower + corner(n)))
    }
}

impl<P: Potential> Surface for OnGrid<'_, P> {
    type Probe = Probe;

    fn probe(&self) -> Probe {
        Probe {
            halo: Box::default(),
            block: None,
        }
    }

    fn value_and_gradient(&self, probe: &mut Probe, home: Vec3, p: Vec3) -> Option<(f32, Vec3)> {
        self.gather(probe, home);
        let Cell { lower, t } = self.cell(p);
        let v = self.corners(probe, lower);
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        // Along z, then y, then x (corners z fastest).
        let e: [f32; 4] = std::array::from_fn(|k| lerp(v[2 * k], v[2 * k + 1], t.z));
        let dz: [f32; 4] = std::array::from_fn(|k| v[2 * k + 1] - v[2 * k]);
        let (f0, f1) = (lerp(e[0], e[1], t.y), lerp(e[2], e[3], t.y));
        let gradient = Vec3::new(
            f1 - f0,
            lerp(e[1] - e[0], e[3] - e[2], t.x),
            lerp(lerp(dz[0], dz[1], t.y), lerp(dz[2], dz[3], t.y), t.x),
        );
        Some((lerp(f0, f1, t.x), gradient / self.xf.dx))
    }

    fn normal(&self, probe: &mut Probe, home: Vec3, p: Vec3) -> Option<Vec3> {
        self.gather(probe, home);
        let Cell { lower, t } = self.cell(p);
        // The 4³ nodes the corners' central differences read, from the probe's halo with
        // no test a node where it holds them all, as it nearly always does (tested a node,
        // the normals cost 2 % of a particle run's instructions).
        let held = probe
            .block
            .map(|coord| lower - coord * BLOCK_DIM)
            .filter(|l| l.min_element() >= -1 && l.max_element() < BLOCK_DIM);
        let gradient = match held {
            Some(l) => {
                let values = &probe.halo.values;
                interpolated_gradient(t, |n| {
                    let m = l + n;
                    values[WideHalo::index(m.x, m.y, m.z)]
                })
            }
            None => interpolated_gradient(t, |n| self.node(probe, lower + n)),
        };
        gradient.try_normalize()
    }
}

/// The central differences at a cell's corners, interpolated at `t` in it; `at(n)` the
/// potential at node n from the cell's lower node.
#[inline(always)]
fn interpolated_gradient(t: Vec3, at: impl Fn(IVec3) -> f32) -> Vec3 {
    (0..8)
        .map(|n| {
            let c = corner(n).as_vec3();
            let w = c * t + (Vec3::ONE - c) * (Vec3::ONE - t);
            let k = corner(n);
            let central = |e: IVec3| at(k + e) - at(k - e);
            w.x * w.y * w.z * Vec3::new(central(IVec3::X), central(IVec3::Y), central(IVec3::Z))
        })
        .sum()
}

/// Corner `n` of a cell (z fastest).
fn corner(n: usize) -> IVec3 {
    IVec3::new((n >> 2) as i32, (n >> 1) as i32 & 1, n as i32 & 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::target::{sample, Sphere, Target};

    #[test]
    fn a_sphere_keeps_its_surface_and_loses_its_slivers_and_facets() {
        let dx = 0.05;
        let sphere = Sphere {
            center: Vec3::new(0.013, -0.021, 0.007),
            radius: 0.83,
        };
        let mut grid = SparseGrid::<f32>::new();
        grid.import(&sample::level_set(&sphere, dx, 3.0), |v| v / (3.0 * dx));
        crate::grid::tube::upkeep(&mut grid);
        let xf = IndexToWorld {
            origin: Vec3::ZERO,
            dx,
        };
        let mut mesh = crate::mesh::Mesh::default();
        crate::polygonize::Polygonizer::default().run(
            &grid,
            xf,
            &mut mesh,
            &mut Default::default(),
        );
        let before = mesh.clone();
        let surface = OnGrid { grid: &grid, xf };
        crate::mesh::relax_on_surface(&mut mesh, (STEPS, REACH * dx), &surface);

        // The surface stays: every vertex on the sphere within 1 % of a voxel (marching
        // cubes' own error on a sampled distance), the volume within 0.1 %.
        let off = |m: &crate::mesh::Mesh| {
            m.positions
                .iter()
                .map(|&p| sphere.distance(p).abs() / dx)
                .fold(0.0, f32::max)
        };
        assert!(
            off(&mesh) < off(&before).max(0.01) + 0.01,
            "{} voxel off, was {}",
            off(&mesh),
            off(&before)
        );
        let (v0, v1) = (before.volume(), mesh.volume());
        assert!((v1 / v0 - 1.0).abs() < 1e-3, "volume {v1} against {v0}");
        assert_eq!(mesh.triangles, before.triangles);
        assert_eq!(mesh.euler_characteristic(), 2);
        // The slivers go, and with them most of the facets' turning.
        let (q0, q1) = (
            before.worst_triangle_quality(),
            mesh.worst_triangle_quality(),
        );
        assert!(q0 < 0.05 && q1 > 0.3, "worst triangle {q0} -> {q1}");
        let radius = dx; // bumps measured over 3 voxels
        let (b0, b1) = (
            crate::measure::look::bumps(&before, radius),
            crate::measure::look::bumps(&mesh, radius),
        );
        assert!(b1 < 0.6 * b0, "facets {b0}° -> {b1}°");
        // Normals: the sphere's, within a degree.
        for (&p, &n) in mesh.positions.iter().zip(&mesh.normals) {
            let exact = (p - sphere.center).normalize();
            assert!(
                n.dot(exact) > 1f32.to_radians().cos(),
                "normal {n} at {p}, sphere's {exact}"
            );
        }
    }
}
