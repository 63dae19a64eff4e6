//! A quick look at a surface: rays sphere-traced through a target's signed distance, shaded
//! with one key light; written as a multi-layer EXR (RGBA beauty, Z depth, N normals in
//! world space, as Nuke and Blender name them) or as an 8-bit PNG by
//! [`crate::io::image`].

use glam::Vec3;
use rayon::prelude::*;

use crate::grid::Aabb;
use crate::target::Target;

/// Where the camera looks from, toward the centre of the framed box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum View {
    /// Looking down −z.
    Front,
    /// Looking down −x.
    Side,
    /// Looking down −y, z up the image.
    Top,
    /// From the (+x, +y, +z) diagonal, slightly above.
    #[default]
    Perspective,
}

/// The scene's up axis: y (Houdini, Maya, Nuke) or z (Blender, 3ds Max).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Up {
    #[default]
    Y,
    Z,
}

/// Where the camera looks (unit direction) and which way is up in the image, for `view`
/// in a scene whose up axis is `up`. The z-up views are the y-up ones turned as Blender
/// turns a y-up scene, (x, y, z) → (x, −z, y): front looks along +y, top down −z.
pub fn camera(view: View, up: Up) -> (Vec3, Vec3) {
    let (direction, image_up) = match view {
        View::Front => (Vec3::NEG_Z, Vec3::Y),
        View::Side => (Vec3::NEG_X, Vec3::Y),
        View::Top => (Vec3::NEG_Y, Vec3::NEG_Z),
        View::Perspective => (Vec3::new(-1.0, -0.7, -1.0).normalize(), Vec3::Y),
    };
    match up {
        Up::Y => (direction, image_up),
        Up::Z => {
            let turn = |v: Vec3| Vec3::new(v.x, -v.z, v.y);
            (turn(direction), turn(image_up))
        }
    }
}

/// One rendered image.
pub struct Render {
    /// The image's width in pixels.
    pub width: usize,
    /// The image's height in pixels.
    pub height: usize,
    /// Linear RGBA, premultiplied; row-major from the top-left pixel.
    pub rgba: Vec<[f32; 4]>,
    /// Distance from the eye along the ray; infinite where the ray missed.
    pub depth: Vec<f32>,
    /// World-space unit normal where the ray hit, zero elsewhere.
    pub normal: Vec<Vec3>,
    /// Where each pixel moves over the next frame, in pixels (u rightward, v upward, as
    /// Nuke's `forward` channels), when the surface's velocity was given
    /// ([`Render::set_motion`]).
    pub motion: Option<Vec<[f32; 2]>>,
    /// The camera it was rendered from.
    pub camera: Camera,
}

/// A pinhole camera: its eye, its orthonormal frame, the tangent of half its vertical
/// field of view and the image's aspect (width over height).
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    /// Where it looks from, world units.
    pub eye: Vec3,
    /// Along the view (a unit vector).
    pub forward: Vec3,
    /// Toward the image's right (a unit vector).
    pub right: Vec3,
    /// Toward the image's top (a unit vector).
    pub up: Vec3,
    /// tan(vertical field of view / 2).
    pub tan_half_fov: f32,
    /// The image's width and height in pixels.
    pub size: (usize, usize),
}

impl Camera {
    fn aspect(&self) -> f32 {
        self.size.0 as f32 / self.size.1.max(1) as f32
    }

    /// The unit ray through the centre of pixel `i` (row-major from the top left).
    pub fn ray(&self, i: usize) -> Vec3 {
        let (width, height) = self.size;
        let (x, y) = (i % width, i / width);
        let t = self.tan_half_fov;
        let u = (2.0 * (x as f32 + 0.5) / width as f32 - 1.0) * t * self.aspect();
        let v = (1.0 - 2.0 * (y as f32 + 0.5) / height as f32) * t;
        (self.forward + self.right * u + self.up * v).normalize()
    }

    /// Where `p` lands on the image, in pixels from the top left (x rightward, y
    /// downward); `None` behind the eye.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32)> {
        let d = p - self.eye;
        let depth = d.dot(self.forward);
        if depth <= 0.0 {
            return None;
        }
        let t = self.tan_half_fov;
        let u = d.dot(self.right) / depth / (t * self.aspect());
        let v = d.dot(self.up) / depth / t;
        let (width, height) = (self.size.0 as f32, self.size.1 as f32);
        Some((0.5 * (u + 1.0) * width, 0.5 * (1.0 - v) * height))
    }
}

impl Render {
    /// The pixels where the ray hit the surface, with the world point and normal hit.
    pub fn hits(&self) -> (Vec<usize>, Vec<Vec3>, Vec<Vec3>) {
        let pixels: Vec<usize> = (0..self.depth.len())
            .filter(|&i| self.depth[i].is_finite())
            .collect();
        let points = pixels
            .iter()
            .map(|&i| self.camera.eye + self.camera.ray(i) * self.depth[i])
            .collect();
        let normals = pixels.iter().map(|&i| self.normal[i]).collect();
        (pixels, points, normals)
    }

    /// The motion pass: each hit pixel's point moved by its `velocities` (world units per
    /// second, one per pixel of [`Render::hits`]) over `duration` seconds, as the image
    /// sees it; 0 where the ray missed.
    pub fn set_motion(
        &mut self,
        hits: &(Vec<usize>, Vec<Vec3>, Vec<Vec3>),
        velocities: &[Vec3],
        duration: f32,
    ) {
        let mut motion = vec![[0.0f32; 2]; self.depth.len()];
        for ((&i, &p), &v) in hits.0.iter().zip(&hits.1).zip(velocities) {
            if let (Some(a), Some(b)) = (
                self.camera.project(p),
                self.camera.project(p + v * duration),
            ) {
                motion[i] = [b.0 - a.0, a.1 - b.1];
            }
        }
        self.motion = Some(motion);
    }
}

/// Renders the zero set of `target` inside `frame` (a box the camera fits: its bounding
/// sphere, whatever the view) from `view` in a scene whose up axis is `up`, marching in
/// steps no longer than `step` once near the surface.
pub fn render(
    target: &dyn Target,
    frame: Aabb,
    (view, up): (View, Up),
    size: (usize, usize),
    step: f32,
) -> Render {
    let (width, height) = size;
    let centre = 0.5 * (frame.min + frame.max);
    let radius = 0.5 * (frame.max - frame.min).length().max(1e-6);
    let (direction, up) = camera(view, up);
    // A 30° vertical field of view whose cone holds the box's bounding sphere.
    let half_fov = 15f32.to_radians();
    let aspect = width as f32 / height.max(1) as f32;
    let fit = half_fov.tan() * aspect.min(1.0);
    let distance = radius / fit.atan().sin();
    let eye = centre - direction * distance;
    let right = direction.cross(up).normalize();
    let up = right.cross(direction);
    let light = (up - right * 0.6 - direction * 0.8).normalize();

    let camera = Camera {
        eye,
        forward: direction,
        right,
        up,
        tan_half_fov: half_fov.tan(),
        size,
    };
    let pixels: Vec<(Option<(f32, Vec3)>, Vec3)> = (0..width * height)
        .into_par_iter()
        .map(|i| {
            let ray = camera.ray(i);
            (trace(target, eye, ray, frame, step), ray)
        })
        .collect();
    let mut out = Render {
        width,
        height,
        rgba: Vec::with_capacity(pixels.len()),
        depth: Vec::with_capacity(pixels.len()),
        normal: Vec::with_capacity(pixels.len()),
        motion: None,
        camera,
    };
    let albedo = Vec3::new(0.72, 0.74, 0.78);
    for (hit, ray) in pixels {
        match hit {
            Some((t, _)) => {
                let p = eye + ray * t;
                let n = normal_at(target, p, 0.5 * step);
                let diffuse = n.dot(light).max(0.0);
                let rim = (1.0 + n.dot(ray)).powi(3) * 0.15;
                let c = albedo * (0.12 + 0.88 * diffuse) + Vec3::splat(rim);
                out.rgba.push([c.x, c.y, c.z, 1.0]);
                out.depth.push(t);
                out.normal.push(n);
            }
            None => {
                out.rgba.push([0.0; 4]);
                out.depth.push(f32::INFINITY);
                out.normal.push(Vec3::ZERO);
            }
        }
    }
    out
}

/// Distance along the ray to the first crossing into the surface, sphere-traced.
fn trace(target: &dyn Target, eye: Vec3, ray: Vec3, frame: Aabb, step: f32) -> Option<(f32, Vec3)> {
    let (near, far) = slab(eye, ray, frame)?;
    let mut t = near;
    let mut d = target.distance(eye + ray * t);
    if d <= 0.0 {
        return Some((t, eye + ray * t));
    }
    while t < far {
        // A level set's distance is clamped to its band: never step past one band's width,
        // nor less than a fraction of a voxel.
        let advance = d.clamp(0.25 * step, 4.0 * step);
        let (t0, d0) = (t, d);
        t += advance;
        d = target.distance(eye + ray * t);
        if d <= 0.0 {
            // Secant between the last point outside and this one inside.
            let t_hit = t0 + advance * d0 / (d0 - d);
            return Some((t_hit, eye + ray * t_hit));
        }
    }
    None
}

/// Entry and exit distances of a ray through a box.
fn slab(eye: Vec3, ray: Vec3, frame: Aabb) -> Option<(f32, f32)> {
    let inv = ray.recip();
    let a = (frame.min - eye) * inv;
    let b = (frame.max - eye) * inv;
    let near = a.min(b).max_element().max(0.0);
    let far = a.max(b).min_element();
    (near < far).then_some((near, far))
}

fn normal_at(target: &dyn Target, p: Vec3, h: f32) -> Vec3 {
    let d = |e: Vec3| target.distance(p + e * h) - target.distance(p - e * h);
    Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z)).normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::target::BoxShape;

    /// Rows and columns of the image the surface covers, as fractions.
    fn extent(image: &Render) -> (f32, f32) {
        let hit = |x: usize, y: usize| image.rgba[y * image.width + x][3] > 0.0;
        let rows = (0..image.height)
            .filter(|&y| (0..image.width).any(|x| hit(x, y)))
            .count();
        let columns = (0..image.width)
            .filter(|&x| (0..image.height).any(|y| hit(x, y)))
            .count();
        (
            rows as f32 / image.height as f32,
            columns as f32 / image.width as f32,
        )
    }

    #[test]
    fn a_z_up_pool_is_a_floor_not_a_wall() {
        // A pool as Blender has it: wide in x and y, shallow in z.
        let pool = BoxShape {
            center: Vec3::ZERO,
            half_size: Vec3::new(1.0, 1.0, 0.05),
        };
        let frame = pool.bounds();
        let front = |up| render(&pool, frame, (View::Front, up), (96, 96), 0.01);
        // Seen from the front of a z-up scene: a thin horizontal band.
        let (rows, columns) = extent(&front(Up::Z));
        assert!(
            rows < 0.15 && columns > 0.5,
            "z up: rows {rows}, columns {columns}"
        );
        // Taken as y up, the same pool faces the camera: a wall.
        let (rows, columns) = extent(&front(Up::Y));
        assert!(
            rows > 0.5 && columns > 0.5,
            "y up: rows {rows}, columns {columns}"
        );
        // The perspective view of a z-up scene has z up in the image: the top face's
        // normals (+z) are seen, the bottom's never.
        let image = render(&pool, frame, (View::Perspective, Up::Z), (96, 96), 0.01);
        let seen = |n: Vec3| image.normal.iter().filter(|m| m.dot(n) > 0.9).count();
        assert!(seen(Vec3::Z) > 100 && seen(Vec3::NEG_Z) == 0);
    }
}
