//! The options `skin`, `particles`, `morph` and `demo` share: the skin's physics and the
//! per-frame outputs, turned into the library's [`SkinParams`] and [`OutputSpec`].

use std::path::PathBuf;

use activeskin::frames::{OutputSpec, UsdSpec};
use activeskin::grid::Precision;
use activeskin::skin::{SkinError, SkinParams};

use super::pattern_arg;
use super::render::{parse_size, UpArg};

/// The skin's physical and numerical options.
#[derive(clap::Args)]
pub struct PhysicsArgs {
    /// Frames per second: the skin advances 1/fps seconds per frame.
    #[arg(long, default_value_t = activeskin::frames::DEFAULT_FPS)]
    pub fps: f64,
    /// Attraction rate α (1/s): the skin closes α × its distance to the target per second.
    #[arg(long, default_value_t = activeskin::skin::speed::DEFAULT_ALPHA)]
    pub alpha: f32,
    /// Surface tension β (world units²/s): smooths, shrinks thin parts and small bubbles
    /// [default: α·Δx²/8: the same smoothing in voxels on every grid, never a sub-step more].
    #[arg(long)]
    pub beta: Option<f32>,
    /// Volume preservation gain γ_V (world units/s).
    #[arg(long, default_value_t = 0.0)]
    pub volume_gain: f32,
    /// Area preservation gain γ_A (world units/s).
    #[arg(long, default_value_t = 0.0)]
    pub area_gain: f32,
    /// Voxel size of the skin (default: the target's for skin, radius/2 for particles).
    #[arg(long)]
    pub voxel_size: Option<f32>,
    // The help's default is the library's.
    #[arg(long, help = smooth_help())]
    pub smooth: Option<f32>,
    /// Storage of the potential: f32, or fixed16 (half the memory).
    #[arg(long, value_enum, default_value_t = PrecisionArg::F32)]
    pub precision: PrecisionArg,
    // The help's figures come from the library's defaults.
    #[arg(long, help = warmup_help())]
    pub warmup: Option<String>,
}

/// `--smooth`'s help, its default the library's.
fn smooth_help() -> String {
    format!(
        "Smoothing of the surface at the particle scale, as each frame settles (it adds up from frame to frame): 0 for none, 2 for twice as much (and twice its cost); the volume kept, droplets and thin sheets spared, never half a voxel from the target [default: {} for particles, 0 for level sets]",
        activeskin::skin::DEFAULT_PARTICLE_SMOOTHING
    )
}

/// `--warmup`'s help, its example computed at the default α and fps.
fn warmup_help() -> String {
    use activeskin::frames::{auto_warmup, DEFAULT_FPS, WARMUP_AUTO_FACTOR};
    let alpha = activeskin::skin::speed::DEFAULT_ALPHA;
    format!(
        "Start this many frames before --frames (not before the sequence's first frame), advancing without writing: a farm chunk then meets the sequential run at its first frame. A number, or `auto`: enough frames for the start to fade to 1/{WARMUP_AUTO_FACTOR} of its offset (ln({WARMUP_AUTO_FACTOR})·fps/α rounded up, {} frames at α {alpha} and {DEFAULT_FPS} fps)",
        auto_warmup(f64::from(alpha), DEFAULT_FPS)
    )
}

/// `--velocity-time`: which frames' velocities carry the liquid between two frames.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum VelocityTime {
    /// Measured with the velocity's scale: the timing under which the scale comes out the
    /// same on every frame pair.
    Auto,
    /// The earlier frame's velocity (grid and FLIP solvers: Houdini, Mantaflow).
    Start,
    /// The mean of both frames' (SPH solvers, many sub-steps per frame).
    Mid,
}

impl VelocityTime {
    /// The timing given, or `auto`'s when nothing was measured.
    pub fn or(self, measured: activeskin::flow::Timing) -> activeskin::flow::Timing {
        match self {
            VelocityTime::Auto => measured,
            VelocityTime::Start => activeskin::flow::Timing::Start,
            VelocityTime::Mid => activeskin::flow::Timing::Mid,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum PrecisionArg {
    F32,
    Fixed16,
}

impl PhysicsArgs {
    /// `--warmup` in frames: 0 when not given; `auto` from α and fps.
    pub fn warmup_frames(&self) -> anyhow::Result<i64> {
        self.warmup_of(self.warmup.as_deref())
    }

    /// A warm-up given as `spec` (a number of frames or `auto`) at this α and fps.
    pub fn warmup_of(&self, spec: Option<&str>) -> anyhow::Result<i64> {
        match spec {
            None => Ok(0),
            Some("auto") => Ok(activeskin::frames::auto_warmup(
                f64::from(self.alpha),
                self.fps,
            )),
            Some(n) => match n.parse::<i64>() {
                Ok(n) if n >= 0 => Ok(n),
                _ => usage!("--warmup must be a number of frames or `auto`, got '{n}'"),
            },
        }
    }

    /// Checked parameters for a skin of voxel size `dx`.
    pub fn params(&self, default_dx: f32) -> anyhow::Result<SkinParams> {
        self.checked(self.physics().params(default_dx))
    }

    /// [`PhysicsArgs::params`] for a skin of particles of `radius` (its own default
    /// smoothing).
    pub fn particle_params(&self, radius: f32, default_dx: f32) -> anyhow::Result<SkinParams> {
        self.checked(self.physics().particle_params(radius, default_dx))
    }

    fn physics(&self) -> activeskin::skin::Physics {
        activeskin::skin::Physics {
            voxel_size: self.voxel_size,
            alpha: self.alpha,
            beta: self.beta,
            volume_gain: self.volume_gain,
            area_gain: self.area_gain,
            precision: match self.precision {
                PrecisionArg::F32 => Precision::F32,
                PrecisionArg::Fixed16 => Precision::Fixed16,
            },
            smoothing: self.smooth,
        }
    }

    fn checked(&self, params: SkinParams) -> anyhow::Result<SkinParams> {
        activeskin::frames::check_fps(self.fps)?;
        // The library checks; its message names the field, said as a flag when printed.
        params.check().map_err(|e| match e {
            SkinError::Parameter { .. } => super::bad_usage(e.to_string()),
            other => other.into(),
        })?;
        Ok(params)
    }
}

/// The files written per frame.
#[derive(clap::Args)]
pub struct OutputArgs {
    /// Skin VDB level sets (grid `surface`): name.####.vdb, name.%04d.vdb, name.$F4.vdb.
    #[arg(long)]
    pub out: Option<String>,
    /// Meshes, OBJ or PLY by extension, same patterns.
    #[arg(long)]
    pub mesh: Option<String>,
    /// Renders: multi-layer EXR (RGBA, Z, N, and the motion pass forward.u/forward.v
    /// with --velocities on) or PNG by extension, same patterns; the camera frames the
    /// first frame's skin and stays put.
    #[arg(long)]
    pub render: Option<String>,
    /// Render size, WIDTHxHEIGHT.
    #[arg(long, default_value = "640x360")]
    pub render_size: String,
    /// A USD shot of the meshes (`.usda`): one time-sampled mesh over the frames, each
    /// frame a layer in a folder beside it (value clips), with normals, velocities and
    /// the particles' attributes (vertex primvars).
    #[arg(long)]
    pub usd: Option<PathBuf>,
    /// World units in meters, for the USD stage (`metersPerUnit`).
    #[arg(long, default_value_t = 1.0)]
    pub meters_per_unit: f64,
    /// Every frame of the shot, when this run writes only some of them: the USD stage
    /// lists them all (farm sets it on its chunks).
    #[arg(long, value_name = "FIRST-LAST", hide = true)]
    pub shot_frames: Option<String>,
    /// The scene's up axis for renders and the USD stage: y (Houdini, Maya) or z (Blender).
    #[arg(long, value_enum, default_value_t = UpArg::Y)]
    pub up: UpArg,
    /// One JSON object per frame (frame, time, sub-steps, band nodes, blocks, area,
    /// volume, Euler characteristic, components, manifold, clean, milliseconds).
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Continue from the last skin VDB already written by --out.
    #[arg(long)]
    pub resume: bool,
    /// The surface's velocity (world units per second), for motion blur: on each vertex
    /// of PLY meshes (`vx vy vz`), as the vector grid `v` on the level set's voxels in
    /// --out VDBs, as the motion pass of EXR renders. The material's motion (the particles', the velocity grid's) and the
    /// skin's own across it; `off` leaves it out.
    #[arg(long, value_name = "on|off", default_value = "on", action = clap::ArgAction::Set, value_parser = clap::builder::BoolishValueParser::new())]
    pub velocities: bool,
    /// Cut the meshes (files, USD shot) to this box, world units: what lies outside is
    /// left out, the surface open on the box's sides (open water, a tank's inside). The
    /// skin, its VDBs, renders and stats' area and volume stay the whole surface's.
    #[arg(long, value_name = "X0,Y0,Z0,X1,Y1,Z1", allow_hyphen_values = true)]
    pub region: Option<String>,
    /// What the liquid meets in the meshes: a VDB level set or a closed OBJ mesh (a tank,
    /// glass, an obstacle), one file or a frame pattern. Where the skin comes within
    /// --collider-gap of it, the surface is carried straight on to it (and
    /// --collider-depth into it), instead of closing into a shell a radius off; the skin
    /// and its VDBs are untouched.
    #[arg(long)]
    pub collider: Option<String>,
    /// How near the skin must come to the collider to be carried on to it, world units
    /// [default: 4 voxels; `particles`: 2 particle radii].
    #[arg(long)]
    pub collider_gap: Option<f32>,
    /// How far into the collider the liquid's surface runs, world units: 0 meets its
    /// face, more overlaps it (renderers want the liquid and the glass to share a face or
    /// overlap, never a gap).
    #[arg(long, default_value_t = 0.0)]
    pub collider_depth: f32,
    /// No progress output.
    #[arg(long, short)]
    pub quiet: bool,
}

impl OutputArgs {
    /// The outputs as the frame loop takes them.
    pub fn spec(&self) -> anyhow::Result<OutputSpec> {
        let render = match &self.render {
            Some(spec) => Some((pattern_arg(spec)?, parse_size(&self.render_size)?)),
            None => None,
        };
        Ok(OutputSpec {
            out: self.out.as_deref().map(pattern_arg).transpose()?,
            mesh: self.mesh.as_deref().map(pattern_arg).transpose()?,
            render,
            up: self.up.into(),
            stats: self.stats.clone(),
            resume: self.resume,
            progress: (!self.quiet).then(super::progress::shown),
            stats_fields: Default::default(),
            reads: Vec::new(),
            side_outputs: Vec::new(),
            velocities: self.velocities,
            usd: self.usd_spec()?,
            surfaces: None,
            region: self.region.as_deref().map(region_arg).transpose()?,
            collider: self.collider_spec()?,
        })
    }

    fn collider_spec(&self) -> anyhow::Result<Option<activeskin::frames::ColliderSpec>> {
        let Some(files) = &self.collider else {
            return Ok(None);
        };
        let spec =
            activeskin::frames::ColliderSpec::new(files, self.collider_gap, self.collider_depth)?;
        Ok(Some(spec))
    }

    fn usd_spec(&self) -> anyhow::Result<Option<UsdSpec>> {
        let shot = match self.shot_frames.as_deref() {
            Some(spec) => match activeskin::sequence::parse_range(spec) {
                Some(range) => Some(range),
                None => usage!("--shot-frames must be FIRST-LAST, got '{spec}'"),
            },
            None => None,
        };
        Ok(self.usd.as_ref().map(|stage| UsdSpec {
            stage: stage.clone(),
            meters_per_unit: self.meters_per_unit,
            shot,
        }))
    }
}

/// A run about to be cut into chunks, as its command sees it.
pub struct Shot<'a> {
    /// Every frame of the shot.
    pub range: (i64, i64),
    /// The skin's settings, as given.
    pub physics: &'a PhysicsArgs,
    /// The outputs, as given.
    pub outputs: &'a OutputArgs,
    /// Options every chunk adds, so that all read the shot alike.
    pub fixed: Vec<String>,
}

/// `--region X0,Y0,Z0,X1,Y1,Z1` as a box; whether it holds anything the library checks.
fn region_arg(spec: &str) -> anyhow::Result<activeskin::grid::Aabb> {
    let numbers: Vec<f32> = spec
        .split(',')
        .map(|n| n.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .unwrap_or_default();
    let [x0, y0, z0, x1, y1, z1] = numbers[..] else {
        usage!("--region must be six numbers X0,Y0,Z0,X1,Y1,Z1, got '{spec}'");
    };
    Ok(activeskin::grid::Aabb {
        min: glam::Vec3::new(x0, y0, z0),
        max: glam::Vec3::new(x1, y1, z1),
    })
}
