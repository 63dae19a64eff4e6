//! What the mesh formats share: the error, the values per vertex, the buffered writer
//! under a temporary name, and records laid out in parallel.

use std::io::Write;
use std::path::Path;

use rayon::prelude::*;

use super::file::{write_atomically, EagerWriteback};

/// Why a mesh file could not be written or read: the file, and the cause.
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct MeshError {
    /// The mesh file being written.
    pub path: std::path::PathBuf,
    #[source]
    /// Why it failed.
    pub source: MeshFault,
}

/// What went wrong with a mesh file.
#[derive(Debug, thiserror::Error)]
pub enum MeshFault {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error("mesh files must end in .obj or .ply")]
    Extension,
    /// An OBJ record that cannot be read (1-based line).
    #[error("line {line}: cannot read '{text}'")]
    Record { line: usize, text: String },
}

impl MeshError {
    pub(crate) fn new(path: &Path, source: impl Into<MeshFault>) -> Self {
        MeshError {
            path: path.to_path_buf(),
            source: source.into(),
        }
    }
}

/// Values per vertex written beside the positions and normals, where the format holds
/// them (PLY; OBJ has no place for them).
#[derive(Debug, Default, Clone, Copy)]
pub struct VertexValues<'a> {
    /// The surface's velocity, world units per second (`vx vy vz`: Houdini reads them as
    /// `v`, Blender as the `velocity` attribute), for motion blur.
    pub velocities: Option<&'a [glam::Vec3]>,
    /// Particle attributes carried onto the surface (`particles --attribute`): a scalar
    /// under its own name, a vector as `NAME_x NAME_y NAME_z`.
    pub attributes: &'a [crate::particles::Attribute],
}

pub(crate) fn write_with(
    path: &Path,
    body: impl FnOnce(&mut (dyn Write + Send)) -> std::io::Result<()>,
) -> Result<(), MeshError> {
    write_atomically(path, |tmp| {
        let mut w = std::io::BufWriter::new(EagerWriteback::create(tmp)?);
        body(&mut w).and_then(|()| w.flush())?;
        w.get_ref().sync()
    })
    .map_err(|e| MeshError::new(path, e))
}

/// Writes `items` as fixed-size binary records of `size` bytes, each laid out by `record`
/// (index, item, its bytes), a chunk at a time in parallel.
pub(crate) fn write_records<T: Sync>(
    w: &mut (dyn Write + Send),
    items: &[T],
    size: usize,
    record: impl Fn(usize, &T, &mut [u8]) + Sync,
) -> std::io::Result<()> {
    const CHUNK: usize = 1 << 16;
    let encode = |c: usize, chunk: &[T], buffer: &mut Vec<u8>| {
        buffer.resize(chunk.len() * size, 0);
        buffer
            .par_chunks_mut(size)
            .zip(chunk)
            .enumerate()
            .for_each(|(i, (out, item))| record(c * CHUNK + i, item, out));
    };
    // One chunk is written while the next is laid out.
    let mut chunks = items.chunks(CHUNK).enumerate();
    let (mut ready, mut next) = (Vec::new(), Vec::new());
    let Some((c, chunk)) = chunks.next() else {
        return Ok(());
    };
    encode(c, chunk, &mut ready);
    for (c, chunk) in chunks {
        let (written, ()) = rayon::join(|| w.write_all(&ready), || encode(c, chunk, &mut next));
        written?;
        std::mem::swap(&mut ready, &mut next);
    }
    w.write_all(&ready)
}
