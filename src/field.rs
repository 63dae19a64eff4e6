//! The settings a run is given, as the library's errors and notes name them.
//!
//! A message names a setting as [`Field`] displays it, `` `radius` ``; each front end says
//! it its own way with [`spell`]: the command line `--radius`, Python `radius=`. So the
//! library's words are written once and no front end's flag leaks into another's.

use std::fmt;

/// A setting named in a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// Particle radius.
    Radius,
    /// Kernel half-support, in radii.
    SmoothingLength,
    /// Density of a fog volume's or a particle density's surface.
    Iso,
    /// The skin's voxel size.
    VoxelSize,
    /// A numpy target's voxel size (Python only).
    Spacing,
    /// Frames a second.
    Fps,
    /// Attraction rate α.
    Alpha,
    /// Surface tension β.
    Beta,
    /// Volume preservation gain γ_V.
    VolumeGain,
    /// Area preservation gain γ_A.
    AreaGain,
    /// Curvature smoothing as a frame settles.
    Smooth,
    /// Narrow band half-width, in voxels (library only).
    BandWidth,
    /// Time-step safety factor (library only).
    Safety,
    /// The farthest target distance the attraction reads (library only).
    Reach,
    /// Velocity units' scale.
    VelocityScale,
    /// Which frames' velocities carry a frame.
    VelocityTime,
    /// The velocity grid's name.
    Velocity,
    /// Velocities ignored.
    NoVelocity,
    /// A level set's distance units.
    TargetUnits,
    /// The frame range.
    Frames,
    /// A missing frame holds the last target.
    HoldMissing,
    /// The target sequence.
    Target,
    /// The particle sequence.
    Particles,
    /// Skin VDB level sets written.
    Out,
    /// Meshes written.
    Mesh,
    /// Renders written.
    Render,
    /// Statistics lines written.
    Stats,
    /// A USD shot written.
    Usd,
    /// The USD stage's metres per unit.
    MetersPerUnit,
    /// The frames of a whole USD shot.
    ShotFrames,
    /// Particle densities written as fog volumes.
    DensityOut,
    /// Continue a run from its last VDB.
    Resume,
    /// The memory budget.
    MaxMemory,
    /// The box the meshes are cut to.
    Region,
    /// What the liquid meets (`--collider`).
    Collider,
    /// How near the skin comes before it is carried to a collider.
    ColliderGap,
    /// How far into a collider the liquid runs.
    ColliderDepth,
}

impl Field {
    /// Every field, for looking one up by name.
    pub const ALL: [Field; 37] = [
        Field::Radius,
        Field::SmoothingLength,
        Field::Iso,
        Field::VoxelSize,
        Field::Spacing,
        Field::Fps,
        Field::Alpha,
        Field::Beta,
        Field::VolumeGain,
        Field::AreaGain,
        Field::Smooth,
        Field::BandWidth,
        Field::Safety,
        Field::Reach,
        Field::VelocityScale,
        Field::VelocityTime,
        Field::Velocity,
        Field::NoVelocity,
        Field::TargetUnits,
        Field::Frames,
        Field::HoldMissing,
        Field::Target,
        Field::Particles,
        Field::Out,
        Field::Mesh,
        Field::Render,
        Field::Stats,
        Field::Usd,
        Field::MetersPerUnit,
        Field::ShotFrames,
        Field::DensityOut,
        Field::Resume,
        Field::MaxMemory,
        Field::Region,
        Field::Collider,
        Field::ColliderGap,
        Field::ColliderDepth,
    ];

    /// The library's name: snake case, as the settings' structs and Python's keywords
    /// mostly spell it.
    pub fn name(self) -> &'static str {
        match self {
            Field::Radius => "radius",
            Field::SmoothingLength => "smoothing_length",
            Field::Iso => "iso",
            Field::VoxelSize => "voxel_size",
            Field::Spacing => "spacing",
            Field::Fps => "fps",
            Field::Alpha => "alpha",
            Field::Beta => "beta",
            Field::VolumeGain => "volume_gain",
            Field::AreaGain => "area_gain",
            Field::Smooth => "smooth",
            Field::BandWidth => "band_width",
            Field::Safety => "safety",
            Field::Reach => "reach",
            Field::VelocityScale => "velocity_scale",
            Field::VelocityTime => "velocity_time",
            Field::Velocity => "velocity",
            Field::NoVelocity => "no_velocity",
            Field::TargetUnits => "target_units",
            Field::Frames => "frames",
            Field::HoldMissing => "hold_missing",
            Field::Target => "target",
            Field::Particles => "particles",
            Field::Out => "out",
            Field::Mesh => "mesh",
            Field::Render => "render",
            Field::Stats => "stats",
            Field::Usd => "usd",
            Field::MetersPerUnit => "meters_per_unit",
            Field::ShotFrames => "shot_frames",
            Field::DensityOut => "density_out",
            Field::Resume => "resume",
            Field::MaxMemory => "max_memory",
            Field::Region => "region",
            Field::Collider => "collider",
            Field::ColliderGap => "collider_gap",
            Field::ColliderDepth => "collider_depth",
        }
    }

    /// The field named `name`.
    pub fn from_name(name: &str) -> Option<Field> {
        Field::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The command line's flag: `--voxel-size`.
    pub fn flag(self) -> String {
        format!("--{}", self.name().replace('_', "-"))
    }
}

/// `` `name` ``: how a message names a field until a front end spells it.
impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}`", self.name())
    }
}

/// `text` with each field it names (`` `radius` ``) said as `say` says it; other
/// back-quoted words (`` `vdb` ``) are left as they are.
pub fn spell(text: &str, say: impl Fn(Field) -> String) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(open) = rest.find('`') {
        out.push_str(&rest[..open]);
        let after = &rest[open + 1..];
        match after
            .find('`')
            .and_then(|close| Some((close, Field::from_name(&after[..close])?)))
        {
            Some((close, field)) => {
                out.push_str(&say(field));
                rest = &after[close + 1..];
            }
            None => {
                out.push('`');
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// `text` as the command line says it: fields as flags.
pub fn on_command_line(text: &str) -> String {
    spell(text, Field::flag)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_spelled_by_each_front_end() {
        for f in Field::ALL {
            assert_eq!(Field::from_name(f.name()), Some(f));
        }
        let text = format!(
            "{} must be positive; give a larger {} (the `vdb` feature, `x`)",
            Field::Radius,
            Field::VoxelSize
        );
        assert_eq!(
            on_command_line(&text),
            "--radius must be positive; give a larger --voxel-size (the `vdb` feature, `x`)"
        );
        assert_eq!(
            spell(&text, |f| format!("{}=", f.name())),
            "radius= must be positive; give a larger voxel_size= (the `vdb` feature, `x`)"
        );
        assert_eq!(on_command_line("a ` lone tick"), "a ` lone tick");
    }
}
