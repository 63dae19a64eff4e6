//! The material's velocity (paper §7): the skin is carried by it, and the attraction only
//! corrects what the motion does not explain. Analytic motions for tests and demos, and
//! velocity grids read from simulation caches.

mod grid;
mod nodes;

use glam::Vec3;

pub use grid::{GridFlow, GridFlowError, EXTENSION_LAYERS, MAX_MOTION_LAYERS};
pub use nodes::OnNodes;

use crate::grid::Aabb;

/// A velocity field, world units per second.
pub trait Flow: Sync + Send {
    fn velocity(&self, p: Vec3) -> Vec3;

    /// Whether a sample costs more than reading eight stored nodes (a velocity grid's
    /// hashed lookups): the skin then samples it once per frame at its nodes ([`OnNodes`]).
    fn costly(&self) -> bool {
        false
    }
}

impl<F: Flow + ?Sized> Flow for &F {
    fn velocity(&self, p: Vec3) -> Vec3 {
        (**self).velocity(p)
    }
    fn costly(&self) -> bool {
        (**self).costly()
    }
}

impl<F: Flow + ?Sized + Send> Flow for std::sync::Arc<F> {
    fn velocity(&self, p: Vec3) -> Vec3 {
        (**self).velocity(p)
    }
    fn costly(&self) -> bool {
        (**self).costly()
    }
}

/// A frame's motion as one map (§7 over a whole frame): where the material now at `p` was
/// `duration` seconds before, `None` where no material is near `p`. When a simulation
/// says where each particle was a frame before, that motion is known exactly at the
/// particles, and the skin is carried by it in one trace a frame
/// ([`crate::skin::Skin::carry`]) instead of sub-steps of a velocity.
pub trait FlowMap: Sync + Send {
    fn departure(&self, p: Vec3, duration: f32) -> Option<Vec3>;
    /// [`FlowMap::departure`] at each node of one block, the node at offset `o` (OpenVDB's
    /// leaf order) at `corner + dx·offset_coords(o)`; node by node unless a map knows
    /// better (a grid sharing the nodes reads them without interpolating).
    fn block_departures(&self, corner: Vec3, dx: f32, duration: f32, out: &mut Vec<Option<Vec3>>) {
        out.clear();
        out.extend((0..crate::grid::BLOCK_NODES).map(|o| {
            self.departure(
                corner + crate::grid::offset_coords(o).as_vec3() * dx,
                duration,
            )
        }));
    }
    /// Where the material is now.
    fn bounds(&self) -> Aabb;
    /// Boxes that together hold the material now: by default its bounds
    /// ([`crate::target::Target::parts`]).
    fn parts(&self) -> Vec<Aabb> {
        vec![self.bounds()]
    }
}

impl<F: FlowMap + ?Sized + Send> FlowMap for std::sync::Arc<F> {
    fn departure(&self, p: Vec3, duration: f32) -> Option<Vec3> {
        (**self).departure(p, duration)
    }
    fn block_departures(&self, corner: Vec3, dx: f32, duration: f32, out: &mut Vec<Option<Vec3>>) {
        (**self).block_departures(corner, dx, duration, out)
    }
    fn bounds(&self) -> Aabb {
        (**self).bounds()
    }
    fn parts(&self) -> Vec<Aabb> {
        (**self).parts()
    }
}

/// A rigid motion: translation at `linear`, rotation at `angular` (radians per second,
/// about its axis, right-handed) around `center`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rigid {
    /// The point the rotation turns about, world units.
    pub center: Vec3,
    /// Translation velocity, world units per second.
    pub linear: Vec3,
    /// Angular velocity: its axis, its length radians per second.
    pub angular: Vec3,
}

impl Flow for Rigid {
    fn velocity(&self, p: Vec3) -> Vec3 {
        self.linear + self.angular.cross(p - self.center)
    }
}

/// A velocity field as a frame's map over `bounds` (everywhere in them): each point traced
/// back through `flow` with RK4 steps of at most `step` world units (64 at most).
pub struct Traced<'a> {
    /// The velocity traced.
    pub flow: &'a dyn Flow,
    /// Where the map answers, world units.
    pub bounds: Aabb,
    /// The longest RK4 step, world units.
    pub step: f32,
}

impl FlowMap for Traced<'_> {
    fn departure(&self, p: Vec3, duration: f32) -> Option<Vec3> {
        let v = |x: Vec3| self.flow.velocity(x);
        // A negative duration traces ahead.
        let reach = v(p).length() * duration.abs();
        let n = (reach / self.step).ceil().clamp(1.0, 64.0);
        let h = -duration / n;
        let mut x = p;
        for _ in 0..n as usize {
            let k1 = v(x);
            let k2 = v(x + 0.5 * h * k1);
            let k3 = v(x + 0.5 * h * k2);
            let k4 = v(x + h * k3);
            x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
        Some(x)
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// Which of a cache's per-frame velocities carry the liquid from one frame to the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Timing {
    /// The earlier frame's: solvers that advect with the velocity they saved, then update
    /// it, a sub-step or two per frame (grid and FLIP solvers: Houdini, Mantaflow).
    #[default]
    Start,
    /// The mean of both frames': many sub-steps per frame (SPH solvers).
    Mid,
}

impl Timing {
    /// The flow over an interval whose frames have the flows `start` and `end`; `mean` is
    /// where [`Timing::Mid`] puts their mean. A missing end takes the other's.
    pub fn interval<'a>(
        self,
        start: Option<&'a dyn Flow>,
        end: Option<&'a dyn Flow>,
        mean: &'a mut Option<Mean<'a>>,
    ) -> Option<&'a dyn Flow> {
        match (self, start, end) {
            (Timing::Mid, Some(a), Some(b)) => Some(mean.insert(Mean(a, b))),
            (_, Some(a), _) => Some(a),
            (_, None, b) => b,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Timing::Start => "start",
            Timing::Mid => "mid",
        }
    }
}

/// The mean of two flows: the velocity over a frame interval from the velocities of the
/// frames at both ends.
pub struct Mean<'a>(pub &'a dyn Flow, pub &'a dyn Flow);

impl Flow for Mean<'_> {
    fn velocity(&self, p: Vec3) -> Vec3 {
        0.5 * (self.0.velocity(p) + self.1.velocity(p))
    }
    fn costly(&self) -> bool {
        self.0.costly() || self.1.costly()
    }
}
