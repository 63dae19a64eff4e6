//! What a frame writes: the skin VDB, the mesh, a render, a stats line, progress. Each
//! file is written under a temporary name and renamed.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use hashbrown::HashMap;

use super::{DataError, FrameError, UsageError};
use crate::field::Field;
use crate::grid::Aabb;
use crate::io::usd;
use crate::render::{self, Up, View};
use crate::sequence::FramePattern;
use crate::skin::velocity::SurfaceMotion;
use crate::skin::{AnySkin, StepStats};
use crate::target::{LevelSetTarget, Target};
#[cfg(feature = "vdb")]
use crate::vdb::{self, Grid, WriteOptions};
use crate::volume::GridData;

/// What a run tells its front end as it goes (a progress bar, a log, a Python callback):
/// the library writes files and prints nothing.
#[derive(Debug, Clone, Copy)]
pub enum Report {
    /// The frames to be written, before the first.
    Start { first: i64, last: i64 },
    /// Frames already written (a resume), skipped.
    Skipped { frames: u64 },
    /// A frame written: its measures and the milliseconds it took.
    Frame {
        frame: i64,
        stats: StepStats,
        milliseconds: f64,
    },
    /// The last frame written.
    Done,
}

/// Who is told of the run ([`Report`]), and whether it wants each frame's Euler
/// characteristic and components (they cost a pass over the mesh; 0 otherwise).
#[derive(Clone)]
pub struct Progress {
    /// Told as the run starts, as each frame is written, and as it ends.
    pub each: Arc<dyn Fn(&Report) + Send + Sync>,
    /// Count each frame's Euler characteristic and components.
    pub topology: bool,
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Progress {{ topology: {} }}", self.topology)
    }
}

/// The files a run writes per frame, each optional (at least one is needed).
#[derive(Debug, Clone)]
pub struct OutputSpec {
    /// Skin VDB level sets (grid `surface`).
    pub out: Option<FramePattern>,
    /// Meshes, OBJ or PLY by extension.
    pub mesh: Option<FramePattern>,
    /// Renders (EXR or PNG by extension) and their size.
    pub render: Option<(FramePattern, (usize, usize))>,
    /// The scene's up axis, for renders.
    pub up: Up,
    /// One JSON object per frame.
    pub stats: Option<PathBuf>,
    /// Continue after the last skin VDB written under `out`.
    pub resume: bool,
    /// Told of each frame; none for a quiet run.
    pub progress: Option<Progress>,
    /// Fields added to every stats line (how the run was set up, e.g. the velocity's
    /// measured scale).
    pub stats_fields: serde_json::Map<String, serde_json::Value>,
    /// The files the run reads: no output may overwrite one of them.
    pub reads: Vec<FramePattern>,
    /// Other files the run writes each frame (the particles' density), with the option
    /// that names them: kept apart from the outputs and the inputs as the outputs are.
    pub side_outputs: Vec<(Field, FramePattern)>,
    /// The surface's velocity, for motion blur, in the outputs that hold one: per vertex
    /// in PLY meshes and USD shots, as the vector grid `v` beside the level set in `--out`
    /// VDBs.
    pub velocities: bool,
    /// A USD shot of the meshes.
    pub usd: Option<UsdSpec>,
    /// Told of each frame's surface as it is written (the Python API hands it over).
    pub surfaces: Option<SurfaceSink>,
    /// The box the meshes (files, USD, the surfaces told) are cut to, open on its sides;
    /// the skin, its VDBs, renders and measures are the whole surface's.
    pub region: Option<Aabb>,
    /// What the liquid meets in the meshes written ([`crate::target::meet_collider`]); the
    /// skin, its VDBs and measures are untouched.
    pub collider: Option<super::ColliderSpec>,
}

/// A frame's surface as the outputs write it: the skin's mesh, the values at its
/// vertices, the frame's measures.
pub struct Surface<'a> {
    /// The frame number.
    pub frame: i64,
    /// The settled skin's mesh (world units, outward).
    pub mesh: &'a crate::mesh::Mesh,
    /// What the mesh's vertices hold beside their normals: the surface's velocity, the
    /// particles' attributes.
    pub values: crate::io::mesh::VertexValues<'a>,
    /// The frame's measures (sub-steps, band, area, volume, topology when asked).
    pub stats: &'a StepStats,
    /// The settled skin, as its VDB holds it.
    pub level_set: &'a GridData,
    /// The surface's velocity at the settled skin's voxels, when the sink asked for it
    /// (the skin VDB's grid `v`).
    pub voxel_velocities: Option<&'a VoxelVelocities>,
}

/// Who is told of each frame's [`Surface`].
#[derive(Clone)]
pub struct SurfaceSink {
    /// Called with each frame's surface, from the frame loop's thread.
    pub each: Arc<dyn Fn(&Surface) + Send + Sync>,
    /// Also the surface's velocity at the skin's voxels, as `--out` writes it.
    pub voxel_velocities: bool,
}

impl std::fmt::Debug for SurfaceSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SurfaceSink")
    }
}

/// A USD shot (`--usd`): the stage, its units, and the shot's frames when this run
/// writes only some of them (a farm chunk; the stage lists them all).
#[derive(Debug, Clone)]
pub struct UsdSpec {
    /// The stage file written (`.usda` or `.usd`, as text).
    pub stage: PathBuf,
    /// The stage's `metersPerUnit`: how long a world unit of the input is.
    pub meters_per_unit: f64,
    /// The whole shot's first and last frames, when this run writes only some.
    pub shot: Option<(i64, i64)>,
}

/// What a frame's outputs write beside the surface: its velocity over the frame (world
/// units per second) and the particles' attributes carried onto it.
#[derive(Default)]
pub struct SurfaceValues {
    /// The velocity at each vertex of the skin's mesh.
    pub mesh: Option<Vec<glam::Vec3>>,
    /// The velocity at each active voxel of the settled level set.
    pub grid: Option<VoxelVelocities>,
    /// Particle attributes at each vertex of the mesh.
    pub attributes: Vec<crate::particles::Attribute>,
}

/// Index coordinates of voxels and the velocity at each.
pub type VoxelVelocities = (Vec<[i32; 3]>, Vec<[f32; 3]>);

/// Writes each frame's outputs and reports progress.
pub struct Outputs {
    resume: bool,
    out: Option<FramePattern>,
    mesh: Option<FramePattern>,
    render: Option<(FramePattern, (usize, usize), Option<Aabb>)>,
    up: Up,
    stats: Option<(PathBuf, Vec<u8>)>,
    stats_fields: serde_json::Map<String, serde_json::Value>,
    progress: Option<Progress>,
    velocities: bool,
    /// The USD shot and whether this run has written its stage yet (with its first frame,
    /// once the attributes it declares are known).
    usd: Option<(UsdSpec, (i64, i64), bool)>,
    /// Frames a second, for the USD stage's time codes.
    fps: f64,
    surfaces: Option<SurfaceSink>,
    region: Option<Aabb>,
    colliders: Option<super::collider::Colliders>,
}

impl Outputs {
    /// Checks the request for frames `first..=last`, creates the output folders and removes
    /// the temporary files a killed run left there for those frames (only those: farm
    /// chunks writing other frames into the same folders may be running).
    pub fn new(spec: &OutputSpec, (first, last): (i64, i64)) -> Result<Self, FrameError> {
        if let Some(out) = &spec.out {
            require_extension(Field::Out, out, "skin level sets (VDB)", &["vdb"])?;
        }
        for (flag, pattern) in &spec.side_outputs {
            require_extension(*flag, pattern, "VDB fog volumes", &["vdb"])?;
        }
        if let Some(mesh) = &spec.mesh {
            require_extension(Field::Mesh, mesh, "meshes", crate::io::mesh::EXTENSIONS)?;
        }
        if let Some((render, _)) = &spec.render {
            require_extension(
                Field::Render,
                render,
                "renders",
                crate::io::image::EXTENSIONS,
            )?;
        }
        let (out, mesh) = (spec.out.clone(), spec.mesh.clone());
        let render = spec.render.clone().map(|(p, size)| (p, size, None));
        let usd = spec
            .usd
            .as_ref()
            .map(|u| shot_of(u, (first, last)))
            .transpose()?;
        let nothing = out.is_none()
            && mesh.is_none()
            && render.is_none()
            && usd.is_none()
            && spec.surfaces.is_none();
        if nothing && spec.stats.is_none() {
            return Err(UsageError::NothingToWrite.into());
        }
        if cfg!(not(feature = "vdb")) && out.is_some() {
            return Err(UsageError::SkinWithoutVdb.into());
        }
        if spec.resume && out.is_none() {
            return Err(UsageError::ResumeWithoutOut.into());
        }
        check_apart(spec, (first, last))?;
        if let Some(region) = spec.region {
            check_region(region)?;
        }
        if let Some(collider) = &spec.collider {
            collider.check()?;
        }
        let usd_frames = usd.as_ref().map(|(_, shot)| shot.frame_pattern());
        let patterns = out.iter().chain(&mesh).chain(render.iter().map(|r| &r.0));
        for pattern in patterns.chain(&usd_frames) {
            create_folder(&pattern.folder())?;
            remove_stale_temporaries(pattern, first..=last);
        }
        // The stats file's folder too, as the others': made before frame 1 is written.
        if let Some(folder) = spec.stats.as_ref().and_then(|s| s.parent()) {
            if !folder.as_os_str().is_empty() {
                create_folder(folder)?;
            }
        }
        if let Some(p) = &spec.progress {
            (p.each)(&Report::Start { first, last });
        }
        Ok(Outputs {
            resume: spec.resume,
            out,
            mesh,
            render,
            up: spec.up,
            stats: spec.stats.clone().map(|p| (p, Vec::new())),
            stats_fields: spec.stats_fields.clone(),
            progress: spec.progress.clone(),
            velocities: spec.velocities,
            usd: usd.map(|(u, shot)| (u, shot.frames, false)),
            fps: 24.0,
            surfaces: spec.surfaces.clone(),
            region: spec.region,
            colliders: spec.collider.clone().map(super::collider::Colliders::new),
        })
    }

    /// Frames a second of the run (the USD stage's time codes a second).
    pub fn set_frame_rate(&mut self, fps: f64) {
        self.fps = fps;
    }

    /// Frames the renders' camera on `mesh`, the skin a run starts from (before a resume
    /// or a warm-up): a resumed run renders its frames as the uninterrupted one did.
    pub fn frame_camera(&mut self, mesh: &crate::mesh::Mesh) {
        if let (Some((_, _, camera)), Some(first)) = (&mut self.render, mesh.positions.first()) {
            let bounds = mesh.positions.iter().fold(
                Aabb {
                    min: *first,
                    max: *first,
                },
                |b, &p| Aabb {
                    min: b.min.min(p),
                    max: b.max.max(p),
                },
            );
            *camera = Some(framing(bounds));
        }
    }

    pub fn resume(&self) -> bool {
        self.resume
    }

    /// Where a frame's surface velocities are written, as (mesh, grid, render): asked
    /// for, and the meshes hold them (PLY, USD), skin VDBs are written, renders are
    /// EXR (a motion pass).
    pub fn wants_velocities(&self) -> (bool, bool, bool) {
        let mesh = self.vertices_hold_values();
        let exr = self
            .render
            .as_ref()
            .is_some_and(|r| crate::io::has_extension(&r.0.path(0), &["exr"]));
        (
            self.velocities && mesh,
            self.velocities
                && (self.out.is_some()
                    || self.surfaces.as_ref().is_some_and(|s| s.voxel_velocities)),
            self.velocities && exr,
        )
    }

    /// Whether meshes are written in a format that holds values per vertex (PLY, USD, or
    /// handed over).
    pub fn vertices_hold_values(&self) -> bool {
        self.usd.is_some()
            || self.surfaces.is_some()
            || self
                .mesh
                .as_ref()
                .is_some_and(|m| crate::io::mesh::holds_values(&m.path(0)))
    }

    /// The skin VDB of a frame, if --out was given and the file exists.
    pub fn written_skin(&self, frame: i64) -> Option<PathBuf> {
        let path = self.out.as_ref()?.path(frame);
        path.is_file().then_some(path)
    }

    /// The settled `level_set` of `frame` meeting the run's collider, when it has one and
    /// the liquid comes near it ([`crate::target::meet_collider`]).
    pub(crate) fn meet_collider(
        &mut self,
        frame: i64,
        level_set: &GridData,
    ) -> Result<Option<GridData>, FrameError> {
        match self.colliders.as_mut() {
            Some(colliders) => colliders.meet(frame, level_set),
            None => Ok(None),
        }
    }

    /// Writes one frame: `level_set` is the skin's settled state
    /// ([`AnySkin::settle`]), `mesh` the surface shown (the skin's, or met with a
    /// collider), `stats` measured on the skin, `velocities` at `mesh`'s vertices
    /// ([`Outputs::wants_velocities`]).
    pub fn write_frame(
        &mut self,
        frame: i64,
        (skin, shown, level_set): (&AnySkin, &crate::mesh::Mesh, &GridData),
        (velocities, motion): (&SurfaceValues, Option<&SurfaceMotion>),
        stats: &StepStats,
        started: Instant,
    ) -> Result<(), FrameError> {
        let values = crate::io::mesh::VertexValues {
            velocities: velocities.mesh.as_deref(),
            attributes: &velocities.attributes,
        };
        let tolerance = 1e-3 * level_set.transform.voxel_size() as f32;
        let cut = self
            .region
            .map(|region| cut_to_region(shown, values, region, tolerance));
        let (mesh, values) = match &cut {
            Some((mesh, velocities, attributes)) => (
                mesh,
                crate::io::mesh::VertexValues {
                    velocities: velocities.as_deref(),
                    attributes,
                },
            ),
            None => (shown, values),
        };
        if let Some(pattern) = &self.mesh {
            crate::io::mesh::write_with_values(mesh, values, &pattern.path(frame))?;
        }
        if let Some((spec, frames, staged)) = &mut self.usd {
            let shot = usd::Shot::new(
                &spec.stage,
                *frames,
                self.fps,
                self.up,
                spec.meters_per_unit,
            );
            if !*staged {
                shot.write_stage(&usd::Carried::of(&values))?;
                *staged = true;
            }
            shot.write_frame(frame, mesh, values)?;
        }
        if let Some(sink) = &self.surfaces {
            (sink.each)(&Surface {
                frame,
                mesh,
                values,
                stats,
                level_set,
                voxel_velocities: velocities.grid.as_ref(),
            });
        }
        if let Some((pattern, size, camera)) = &mut self.render {
            let data = level_set;
            let dx = data.transform.voxel_size() as f32;
            let target = LevelSetTarget::new(data);
            let bounds = target.bounds();
            let frame_box = *camera.get_or_insert_with(|| framing(bounds));
            let mut image =
                render::render(&target, frame_box, (View::Perspective, self.up), *size, dx);
            if let Some(motion) = motion {
                // The surface's velocity where each pixel's ray hit it.
                let hits = image.hits();
                let velocities = motion.at(&hits.1, &hits.2, None);
                image.set_motion(&hits, &velocities, motion.duration);
            }
            crate::io::image::write(&image, &pattern.path(frame))?;
        }
        let ms = started.elapsed().as_secs_f64() * 1e3;
        // Measured on the mesh written (the settled skin's), like χ and the components.
        let check = if self.stats.is_some() {
            mesh.check()
        } else {
            Default::default()
        };
        // Cut to a region, the mesh is open on its sides: manifold with that boundary.
        let manifold = match self.region {
            Some(_) => check.manifold_with_boundary(),
            None => check.manifold(),
        };
        let clean = match self.region {
            Some(_) => check.is_clean_with_boundary(),
            None => check.is_clean(),
        };
        let mut line = serde_json::json!({
            "frame": frame,
            "time": skin.time(),
            "substeps": stats.substeps,
            "band_nodes": stats.band_nodes,
            "blocks": stats.blocks,
            "area": stats.area,
            "volume": stats.volume,
            "euler_characteristic": stats.euler_characteristic,
            "components": stats.components,
            "manifold": manifold,
            "clean": clean,
            "milliseconds": ms,
        });
        if let Some(fields) = line.as_object_mut() {
            fields.extend(self.stats_fields.clone());
        }
        if let Some((path, lines)) = &mut self.stats {
            lines.extend_from_slice(line.to_string().as_bytes());
            lines.push(b'\n');
            write_file(path, lines)?;
        }
        // The skin VDB last: --resume restarts after the last one found, so every other
        // output of its frame must already be on disk (a kill between them used to leave
        // that frame without its mesh or stats line).
        #[cfg(feature = "vdb")]
        if let Some(pattern) = &self.out {
            write_skin_vdb(
                &pattern.path(frame),
                frame,
                level_set,
                velocities.grid.as_ref(),
            )?;
        }
        self.tell(&Report::Frame {
            frame,
            stats: *stats,
            milliseconds: ms,
        });
        Ok(())
    }

    /// Whether a frame's χ and components are written or printed ([`Outputs::write_frame`]
    /// reads them from its stats).
    pub fn reports_topology(&self) -> bool {
        self.stats.is_some()
            || self.surfaces.is_some()
            || self.progress.as_ref().is_some_and(|p| p.topology)
    }

    fn tell(&self, report: &Report) {
        if let Some(p) = &self.progress {
            (p.each)(report);
        }
    }

    /// Keeps the stats of frames already written when resuming: the lines before `frame`.
    pub fn resume_stats(&mut self, frame: i64) -> Result<(), FrameError> {
        let Some((path, lines)) = &mut self.stats else {
            return Ok(());
        };
        let Ok(old) = std::fs::read_to_string(&*path) else {
            return Ok(());
        };
        for line in old.lines() {
            let value: serde_json::Value = serde_json::from_str(line)
                .map_err(|_| FrameError::from(DataError::NotStats { path: path.clone() }))?;
            if value["frame"].as_i64().is_some_and(|f| f < frame) {
                lines.extend_from_slice(line.as_bytes());
                lines.push(b'\n');
            }
        }
        Ok(())
    }

    pub fn skip(&self, frames: u64) {
        self.tell(&Report::Skipped { frames });
    }

    pub fn finish(&self) {
        self.tell(&Report::Done);
    }
}

/// Writes frame `frame` of the USD shot `spec` (its `shot` the shot's frames) outside a
/// frame loop, as a run writing it would: the frame's layer, and the stage and manifest,
/// which every frame of a shot writes the same (the Python package's `Mesh.save_usd`).
pub fn write_usd_frame(
    spec: &UsdSpec,
    frame: i64,
    (fps, up): (f64, Up),
    mesh: &crate::mesh::Mesh,
    values: crate::io::mesh::VertexValues,
) -> Result<(), FrameError> {
    if let Some((first, last)) = spec.shot.filter(|&(a, b)| !(a..=b).contains(&frame)) {
        return Err(UsageError::FrameOutsideShot { frame, first, last }.into());
    }
    super::check_fps(fps)?;
    let (_, mut shot) = shot_of(spec, (frame, frame))?;
    (shot.fps, shot.up) = (fps, up);
    create_folder(&shot.folder())?;
    shot.write_stage(&usd::Carried::of(&values))?;
    Ok(shot.write_frame(frame, mesh, values)?)
}

/// Makes an output folder (and those above it) when missing.
/// `mesh` and its vertices' values cut to `region` ([`crate::mesh::clip_to_box`]).
fn cut_to_region(
    mesh: &crate::mesh::Mesh,
    values: crate::io::mesh::VertexValues,
    region: Aabb,
    tolerance: f32,
) -> (
    crate::mesh::Mesh,
    Option<Vec<glam::Vec3>>,
    Vec<crate::particles::Attribute>,
) {
    use crate::mesh::VertexChannel;
    let flat: Option<Vec<f32>> = values
        .velocities
        .map(|v| v.iter().flat_map(|v| v.to_array()).collect());
    let channels: Vec<VertexChannel> = flat
        .iter()
        .map(|v| VertexChannel {
            values: v,
            components: 3,
        })
        .chain(values.attributes.iter().map(|a| VertexChannel {
            values: &a.values,
            components: a.components,
        }))
        .collect();
    let (cut, mut channels) = crate::mesh::clip_to_box(mesh, region, &channels, tolerance);
    let velocities = flat.map(|_| {
        channels
            .remove(0)
            .chunks_exact(3)
            .map(glam::Vec3::from_slice)
            .collect()
    });
    let attributes = values
        .attributes
        .iter()
        .zip(channels)
        .map(|(a, values)| crate::particles::Attribute {
            name: a.name.clone(),
            components: a.components,
            values,
        })
        .collect();
    (cut, velocities, attributes)
}

/// A region that holds something: finite, each side longer than nothing.
pub(crate) fn check_region(region: Aabb) -> Result<(), FrameError> {
    let finite = region.min.is_finite() && region.max.is_finite();
    if finite && region.min.cmplt(region.max).all() {
        return Ok(());
    }
    let [a, b, c] = region.min.to_array();
    let [d, e, f] = region.max.to_array();
    Err(UsageError::EmptyRegion {
        given: format!("({a}, {b}, {c}) to ({d}, {e}, {f})"),
    }
    .into())
}

fn create_folder(folder: &Path) -> Result<(), FrameError> {
    std::fs::create_dir_all(folder).map_err(|source| {
        DataError::CreateFolder {
            folder: folder.into(),
            source,
        }
        .into()
    })
}

/// The USD shot asked for, checked, over the frames `written` unless it says whose.
fn shot_of(spec: &UsdSpec, written: (i64, i64)) -> Result<(UsdSpec, usd::Shot), FrameError> {
    let stage = &spec.stage;
    let name = stage.file_name().map(|n| n.to_string_lossy().into_owned());
    if crate::io::has_extension(stage, &["usdc", "usdz"]) {
        return Err(UsageError::UsdBinary {
            stage: stage.clone(),
        }
        .into());
    }
    if !crate::io::has_extension(stage, usd::EXTENSIONS) {
        return Err(UsageError::UsdExtension {
            stage: stage.clone(),
        }
        .into());
    }
    if name.is_some_and(|n| n.contains(['@', '"', '#', '%', '$', '\\'])) {
        return Err(UsageError::UsdName {
            stage: stage.clone(),
        }
        .into());
    }
    super::usage::positive(Field::MetersPerUnit, spec.meters_per_unit)?;
    let frames = spec.shot.unwrap_or(written);
    if frames.0 > written.0 || frames.1 < written.1 {
        return Err(UsageError::ShotTooShort {
            shot: frames,
            written,
        }
        .into());
    }
    let spec = UsdSpec {
        shot: Some(frames),
        ..spec.clone()
    };
    let shot = usd::Shot::new(stage, frames, 24.0, Up::Y, spec.meters_per_unit);
    Ok((spec, shot))
}

/// The box a render's camera frames around a skin's `bounds`.
fn framing(bounds: Aabb) -> Aabb {
    bounds.padded(0.25 * (bounds.max - bounds.min).max_element())
}

/// Refuses, before anything is written, outputs that would overwrite a file the run reads
/// (`spec.reads`: the same path, or a symlink or hard link to it) or each other, for
/// frames `first..=last`: one typo in a pattern would otherwise replace a whole cache.
fn check_apart(spec: &OutputSpec, (first, last): (i64, i64)) -> Result<(), FrameError> {
    // More frames than a run could write are not listed (the check would be the cost).
    const MOST: i64 = 1 << 20;
    let frames = || first..=last.min(first.saturating_add(MOST));
    let paths = |pattern: &FramePattern| -> Vec<PathBuf> {
        if pattern.is_held() {
            vec![pattern.path(first)]
        } else {
            frames().map(|f| pattern.path(f)).collect()
        }
    };
    let mut read = HashMap::new();
    for pattern in &spec.reads {
        for path in paths(pattern) {
            if let Some(id) = file_id(&path) {
                read.entry(id).or_insert(path);
            }
        }
    }
    let mut written: HashMap<PathBuf, Field> = HashMap::new();
    let outputs = [
        (Field::Out, spec.out.as_ref()),
        (Field::Mesh, spec.mesh.as_ref()),
    ]
    .into_iter()
    .chain([(Field::Render, spec.render.as_ref().map(|r| &r.0))])
    .chain(spec.side_outputs.iter().map(|(flag, p)| (*flag, Some(p))))
    .filter_map(|(flag, p)| p.map(|p| (flag, paths(p))))
    .chain(spec.stats.iter().map(|p| (Field::Stats, vec![p.clone()])))
    .chain(spec.usd.iter().flat_map(|u| {
        let shot = usd::Shot::new(&u.stage, (first, last), 24.0, Up::Y, 1.0);
        let frames = paths(&shot.frame_pattern());
        [
            (Field::Usd, vec![u.stage.clone(), shot.manifest_path()]),
            (Field::Usd, frames),
        ]
    }));
    for (flag, paths) in outputs {
        for path in paths {
            // Lexically too: `new/../input` names the input once `new` is created.
            let id = file_id(&path).or_else(|| file_id(&lexical(&path)));
            if let Some(input) = id.and_then(|id| read.get(&id)) {
                return Err(UsageError::OverwritesInput {
                    field: flag,
                    input: input.clone(),
                }
                .into());
            }
            if let Some(other) = written.insert(lexical(&path), flag) {
                return Err(UsageError::SameOutput {
                    first: other,
                    second: flag,
                    path,
                }
                .into());
            }
        }
    }
    Ok(())
}

/// What makes a file itself whatever path leads to it: device and inode (symlinks
/// followed); `None` when it does not exist.
#[cfg(unix)]
fn file_id(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(path: &Path) -> Option<PathBuf> {
    std::fs::canonicalize(path).ok()
}

/// `path` made absolute, `.` and `..` resolved without touching the disk (outputs need not
/// exist yet).
fn lexical(path: &Path) -> PathBuf {
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = PathBuf::new();
    for part in absolute.components() {
        match part {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

/// Removes the temporary files a killed run left behind for this pattern's `frames`
/// (`.NAME.PID.tmp`, see [`crate::io::temporary_path`]).
fn remove_stale_temporaries(pattern: &FramePattern, frames: std::ops::RangeInclusive<i64>) {
    let folder = pattern.folder();
    let Ok(entries) = std::fs::read_dir(&folder) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(inner) = name.strip_prefix('.').and_then(|n| n.strip_suffix(".tmp")) else {
            continue;
        };
        let Some((frame_file, pid)) = inner.rsplit_once('.') else {
            continue;
        };
        let frame_path = pattern.path(0).with_file_name(frame_file);
        let ours = pid.bytes().all(|b| b.is_ascii_digit())
            && frame_path
                .to_str()
                .and_then(|p| pattern.frame_of(p))
                .is_some_and(|f| frames.contains(&f));
        if ours {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), FrameError> {
    crate::io::write_atomically(path, |tmp| {
        std::fs::File::create(tmp).and_then(|mut f| f.write_all(bytes))
    })
    .map_err(|source| {
        FrameError::Write(crate::io::WriteError {
            path: path.to_path_buf(),
            source,
        })
    })
}

/// A usage error unless `pattern`'s files end in one of `extensions`.
fn require_extension(
    flag: Field,
    pattern: &FramePattern,
    what: &'static str,
    extensions: &[&'static str],
) -> Result<(), FrameError> {
    if !crate::io::has_extension(&pattern.path(0), extensions) {
        return Err(UsageError::Extension {
            field: flag,
            pattern: pattern.clone(),
            what,
            extensions: extensions.to_vec(),
        }
        .into());
    }
    Ok(())
}

/// Writes a frame's skin as `--out` does: the settled level set as grid `surface`, with
/// the frame's number, and its velocity at the voxels (grid `v`) when given.
#[cfg(feature = "vdb")]
pub fn write_skin_vdb(
    path: &std::path::Path,
    frame: i64,
    level_set: &GridData,
    velocities: Option<&VoxelVelocities>,
) -> Result<(), FrameError> {
    let grid = Grid::from_data(level_set)?;
    let meta = vdb::frame_metadata(frame);
    let vectors: Vec<vdb::VectorWrite> = velocities
        .iter()
        .map(|(coords, values)| vdb::VectorWrite {
            // Houdini's name for a velocity on geometry, which VDB Sample
            // copies onto a mesh's points for motion blur.
            name: "v",
            staggered: false,
            voxel_size: level_set.transform.voxel_size(),
            coords,
            values,
            // Three digits are plenty for a blur, and the file stays 1.5× the
            // level set's size, not 3×.
            half_float: true,
        })
        .collect();
    vdb::write_grids_and_vectors(path, &[(&grid, WriteOptions::default())], &vectors, &meta)?;
    Ok(())
}
