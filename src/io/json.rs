//! splashsurf's JSON particle files: `[[x, y, z], …]`.

use glam::Vec3;

use crate::particles::Particles;

/// splashsurf's JSON particle file: an array of `[x, y, z]` arrays.
pub(crate) fn read_json(bytes: &[u8]) -> Result<Particles, serde_json::Error> {
    let points: Vec<[f32; 3]> = serde_json::from_slice(bytes)?;
    Ok(Particles {
        positions: points.into_iter().map(Vec3::from_array).collect(),
        ..Particles::default()
    })
}
