//! splashsurf's JSON particle files: `[[x, y, z], …]`.

use glam::Vec3;

use crate::particles::Particles;

/// splashsurf's JSON particle file: an array of `[x, y, z]` arrays.
pub(crate) fn read_json(bytes: &[u8]) -> Result<Particles, String> {
    let points: Vec<[f32; 3]> = serde_json::from_slice(bytes)
        .map_err(|e| format!("not a JSON array of [x, y, z] points: {e}"))?;
    Ok(Particles {
        positions: points.into_iter().map(Vec3::from_array).collect(),
        ..Particles::default()
    })
}
