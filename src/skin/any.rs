//! A skin whose storage (f32 or 16-bit fixed point) is chosen at run time.

use super::{Skin, SkinError, SkinParams, SpeedParams, StepStats};
use crate::flow::{Flow, FlowMap};
use crate::grid::{Fixed16, Precision};
use crate::mesh::Mesh;
use crate::target::Target;
use crate::volume::GridData;

/// A skin whose storage was chosen at run time.
pub enum AnySkin {
    F32(Skin<f32>),
    Fixed16(Skin<Fixed16>),
}

macro_rules! each {
    ($self:expr, $s:ident => $body:expr) => {
        match $self {
            AnySkin::F32($s) => $body,
            AnySkin::Fixed16($s) => $body,
        }
    };
}

impl AnySkin {
    /// [`AnySkin::new`] with its parameters checked first ([`SkinParams::check`]).
    pub fn try_new(start: &dyn Target, params: SkinParams) -> Result<Self, SkinError> {
        Ok(match params.precision {
            Precision::F32 => AnySkin::F32(Skin::try_new(start, params)?),
            Precision::Fixed16 => AnySkin::Fixed16(Skin::try_new(start, params)?),
        })
    }
    /// [`Skin::check_target`].
    pub fn check_target(&self, target: &dyn Target) -> Result<(), SkinError> {
        each!(self, s => s.check_target(target))
    }
    pub fn new(start: &dyn Target, params: SkinParams) -> Self {
        match params.precision {
            Precision::F32 => AnySkin::F32(Skin::new(start, params)),
            Precision::Fixed16 => AnySkin::Fixed16(Skin::new(start, params)),
        }
    }
    pub fn advance(&mut self, target: &dyn Target, duration: f64) -> StepStats {
        each!(self, s => s.advance(target, duration))
    }
    pub fn advance_in_flow(
        &mut self,
        target: &dyn Target,
        flow: Option<&dyn Flow>,
        duration: f64,
    ) -> StepStats {
        each!(self, s => s.advance_in_flow(target, flow, duration))
    }
    pub fn carry(&mut self, map: &dyn FlowMap, duration: f32) {
        each!(self, s => s.carry(map, duration))
    }
    pub fn follow(
        &mut self,
        target: &dyn Target,
        flow: &dyn Flow,
        duration: f64,
        volume_before: Option<f64>,
    ) -> StepStats {
        each!(self, s => s.follow(target, flow, duration, volume_before))
    }
    pub fn stats(&self) -> StepStats {
        each!(self, s => s.stats())
    }
    pub fn params(&self) -> &SkinParams {
        each!(self, s => s.params())
    }
    pub fn stats_with(&self, topology: bool) -> StepStats {
        each!(self, s => s.stats_with(topology))
    }
    pub fn mesh(&self) -> &Mesh {
        each!(self, s => s.mesh())
    }
    pub fn to_level_set(&self) -> GridData {
        each!(self, s => s.to_level_set())
    }
    pub fn time(&self) -> f64 {
        each!(self, s => s.time())
    }
    pub fn memory_bytes(&self) -> usize {
        each!(self, s => s.memory_bytes())
    }
    pub fn set_speed(&mut self, speed: SpeedParams) {
        each!(self, s => s.set_speed(speed))
    }
    pub fn restore(&mut self, data: &GridData) -> Result<(), SkinError> {
        each!(self, s => s.restore(data))
    }
    pub fn set_time(&mut self, time: f64) {
        each!(self, s => s.set_time(time))
    }
    pub fn limit_substeps(&mut self, most: Option<u32>) {
        each!(self, s => s.limit_substeps(most))
    }
    pub fn count_topology(&mut self, on: bool) {
        each!(self, s => s.count_topology(on))
    }
    pub fn seed(&mut self, target: &dyn Target) -> usize {
        each!(self, s => s.seed(target))
    }
    pub fn settle(&mut self) -> GridData {
        each!(self, s => s.settle())
    }
    pub fn settle_holding(
        &mut self,
        volume: Option<f64>,
        near: Option<&dyn Target>,
        particles: Option<(&dyn Target, &super::Spray, &super::Cover)>,
    ) -> GridData {
        each!(self, s => s.settle_holding(volume, near, particles))
    }
}
