from os import PathLike
from typing import Callable, Mapping, Sequence

import numpy as np
import numpy.typing as npt

__version__: str
HAS_VDB: bool
"""Whether this build reads and writes VDB files (built with the `vdb` feature)."""
DEFAULT_ALPHA: float
"""The attraction rate α (1/s) the skins and the commands take when none is given."""
DEFAULT_FPS: float
"""The frame rate the skins and the commands take when none is given."""
DEFAULT_PARTICLE_SMOOTHING: float
"""The smoothing a `ParticleSkin` takes when `smooth` is not given (level sets: none)."""

def frame_path(pattern: str | PathLike[str], frame: int) -> PathLike[str]:
    """A frame's file in a pattern as the commands name it: ``####``, ``%04d`` and ``$F4``
    padded, ``#``, ``$F`` and ``{}`` unpadded (SPlisHSPlasH's, splashsurf's)."""

def sequence_frames(
    pattern: str | PathLike[str], frames: tuple[int, int] | None = None
) -> tuple[int, int, list[int], bool]:
    """(first, last, found, held): the range (frames, else every frame found), the frames
    on disk, and whether pattern is one file held for every frame (a file without a frame
    number, frames given). ValueError as the commands refuse a sequence."""

def warmup_frames(alpha: float = ..., fps: float = ...) -> int:
    """The frames a farm chunk or a resumed bake warms up on, as --warmup auto:
    ceil(ln(40)·fps/alpha), 23 at the defaults."""

class Mesh:
    """One frame's surface; the arrays are handed over from Rust without a copy."""

    vertices: npt.NDArray[np.float32]
    """Vertex positions, (n, 3), world units."""
    triangles: npt.NDArray[np.uint32]
    """Vertex indices, (m, 3), counter-clockwise seen from outside."""
    normals: npt.NDArray[np.float32]
    """Unit outward normals, (n, 3)."""
    velocities: npt.NDArray[np.float32] | None
    """The surface's velocity at each vertex, (n, 3), world units per second."""
    attributes: dict[str, npt.NDArray[np.float32]]
    """The particles' attributes at each vertex: (n,) or (n, 3)."""
    frame: int
    stats: dict[str, float | int]
    """frame, time, substeps, band_nodes, blocks, area, volume, euler_characteristic, components."""

    def save(self, path: str | PathLike[str]) -> None:
        """Writes OBJ or PLY by the extension (PLY with velocities and attributes)."""
    def save_usd(
        self,
        stage: str | PathLike[str],
        frames: tuple[int, int],
        *,
        fps: float = ...,
        up: str = "y",
        meters_per_unit: float = 1.0,
    ) -> None:
        """Writes this frame of the USD shot `stage` (.usda) over `frames` (first, last),
        as the command's --usd does: the frame's layer (shot/shot.0012.usda beside
        shot.usda) and the stage, the same for every frame. up: the stage's up axis,
        "y" or "z" (Blender's)."""

class ParticleSkin:
    """A skin advanced one frame at a time by a particle simulation's particles."""

    def __init__(
        self,
        radius: float,
        *,
        voxel_size: float | None = None,
        alpha: float = ...,
        beta: float | None = None,
        smooth: float | None = None,
        smoothing_length: float = ...,
        iso: float | None = None,
        fps: float = ...,
        velocities: bool = True,
        hold_volume: bool = True,
        attributes: Sequence[str] | None = None,
        first_frame: int = 1,
        ignore_radii: bool = False,
        volume_reference: tuple[int, npt.ArrayLike, npt.ArrayLike | None] | None = None,
        velocity_grid: bool = False,
        region: tuple[Sequence[float], Sequence[float]] | None = None,
        collider: str | PathLike[str] | None = None,
        collider_gap: float | None = None,
        collider_depth: float = 0.0,
    ) -> None:
        """radius: half the particles' rest spacing; voxel_size defaults to radius/2;
        alpha (1/s) the attraction; beta (world units²/s) the surface tension, by default
        alpha·voxel²/8; smooth: smoothing at the particle scale, 1 by default (0 none,
        2 twice as much), as the command's --smooth; attributes: names to carry onto
        the surface, or ["all"];
        volume_reference: (frame, positions, radii or None) of the sequence's first
        frame when the skin starts later (the volume those particles stand for is held,
        as the command holds it); velocity_grid: the surface's velocity at the skin's
        voxels too, each frame, which save_vdb writes as grid v as the command's --out
        does (on the dam break it adds about half to a frame's time);
        region: ((x0, y0, z0), (x1, y1, z1)), the surfaces cut to that box and open on
        its sides (the command's --region); collider: a VDB level set or a closed OBJ
        (or a frame pattern of them, # for the number) the surfaces meet, carried on to
        it where the skin comes within collider_gap (3 radii by default) and
        collider_depth into it (the command's --collider; a VDB needs HAS_VDB).
        Raises ValueError with the command's message for parameters that cannot make a
        skin."""

    def advance(
        self,
        positions: npt.ArrayLike,
        velocities: npt.ArrayLike | None = None,
        ids: npt.ArrayLike | None = None,
        attributes: Mapping[str, npt.ArrayLike] | None = None,
        radii: npt.ArrayLike | None = None,
    ) -> Mesh:
        """The next frame's particles (positions (n, 3); velocities (n, 3) in world units
        per second; ids (n,); attributes (n,) or (n, 3) by name) in, its surface out.
        Releases the GIL while the frame computes; Ctrl-C raises KeyboardInterrupt."""

    @property
    def attributes(self) -> list[str] | None: ...
    @property
    def mesh(self) -> Mesh | None:
        """The surface of the frame last advanced to."""
    @property
    def stats(self) -> dict[str, float | int] | None:
        """The last frame's measures."""
    def save_vdb(self, path: str | PathLike[str]) -> None:
        """Writes the last frame's skin as a VDB level set (grid `surface`, and `v` with
        velocity_grid), as the command's --out does. Needs HAS_VDB."""

Target = str | PathLike[str] | npt.ArrayLike

class LevelSetSkin:
    """A skin advanced one frame at a time by level sets (Mantaflow's phi, Houdini's
    surface) or fog volumes: the `skin` command's frame loop; `morph`'s with
    seed=False and init."""

    def __init__(
        self,
        *,
        voxel_size: float | None = None,
        alpha: float = ...,
        beta: float | None = None,
        smooth: float | None = None,
        volume_gain: float = 0.0,
        area_gain: float = 0.0,
        fps: float = ...,
        velocities: bool = True,
        velocity_time: str = "start",
        velocity_scale: float = 1.0,
        iso: float | None = None,
        units: str = "auto",
        first_frame: int = 1,
        seed: bool = True,
        init: Target | None = None,
        spacing: float | None = None,
        origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
        grid: str | None = None,
        velocity_grid: bool = False,
        region: tuple[Sequence[float], Sequence[float]] | None = None,
        collider: str | PathLike[str] | None = None,
        collider_gap: float | None = None,
        collider_depth: float = 0.0,
    ) -> None:
        """voxel_size: the skin's, by default the first target's; alpha (1/s) the
        attraction; beta the surface tension (default alpha·voxel²/8); smooth: smoothing
        as each frame settles (none by default), as the command's --smooth; velocity_time
        "start" (FLIP, Mantaflow) or "mid" (SPH): which frames' velocities carry an
        interval; iso: read targets as fog volumes at this density; units: what level
        sets' distances are in ("auto" measures |∇φ|, "world", "voxel"); seed: grow the
        skin where the target has material it has none near (False for a morph); init:
        the shape to start on instead of the first target (its `grid`); spacing, origin:
        where array targets' voxels are (voxel (i, j, k) at origin + (i, j, k)·spacing);
        velocity_grid: the surface's velocity at the skin's voxels too, which save_vdb
        writes as grid v (as the command's --out); region, collider, collider_gap
        (4 voxels by default), collider_depth: as ParticleSkin's.
        Raises ValueError with the command's message for parameters that cannot make a
        skin."""

    def advance(
        self,
        target: Target,
        velocity: npt.ArrayLike | str | bool | None = None,
        *,
        spacing: float | None = None,
        origin: tuple[float, float, float] | None = None,
        grid: str | None = None,
    ) -> Mesh:
        """The next frame's target in, its surface out: a VDB file's path (its `grid`;
        velocity None reads its vel, v or velocity grid, False none, a string that grid)
        or an (nx, ny, nz) array (velocity an (nx, ny, nz, 3) array, world units per
        second). Releases the GIL while the frame computes; Ctrl-C raises
        KeyboardInterrupt."""

    @property
    def mesh(self) -> Mesh | None:
        """The surface of the frame last advanced to."""
    @property
    def stats(self) -> dict[str, float | int] | None:
        """The last frame's measures."""
    def save_vdb(self, path: str | PathLike[str]) -> None:
        """Writes the last frame's skin as a VDB level set (grid `surface`, and `v` with
        velocity_grid), as the command's --out does. Needs HAS_VDB."""

def set_memory_budget(gb: float) -> None:
    """Sets the most memory a frame may take, in GB, as the command's --max-memory does
    (0 for the default: three quarters of the machine's memory). Work that would take
    more is refused with MemoryError before it is allocated, a frame of more particles
    than the budget holds at 128 bytes a particle before its arrays are copied."""

def memory_budget() -> float:
    """The most memory a frame may take, in GB (set_memory_budget)."""

def read_particles(path: str | PathLike[str]) -> dict[str, object]:
    """One particle file as the command reads it (PLY, VTK, VTU, BGEO, JSON, CSV, XYZ):
    positions (n, 3) float32; velocities (n, 3), ids (n,) int64 and radii (n,) or None;
    attributes, a dict of (n,) or (n, 3) arrays by name. ValueError with the command's
    message for a file it cannot read."""

def particles_sequence(
    pattern: str | PathLike[str],
    radius: float,
    *,
    frames: tuple[int, int] | None = None,
    mesh: str | PathLike[str] | None = None,
    progress: Callable[[Mesh], object] | None = None,
    use_velocity: bool = True,
    voxel_size: float | None = None,
    alpha: float = ...,
    beta: float | None = None,
    smooth: float | None = None,
    smoothing_length: float = ...,
    iso: float | None = None,
    fps: float = ...,
    velocities: bool = True,
    hold_volume: bool = True,
    attributes: Sequence[str] | None = None,
) -> int:
    """The `particles` command as a function: the files of `pattern` (#### or %04d padded,
    # unpadded) over `frames`, each frame's mesh written to the `mesh` pattern, progress
    called after each frame. The command's meshes, byte for byte."""

def skin_for_sequence(
    pattern: str | PathLike[str],
    *,
    frames: tuple[int, int],
    first_frame: int | None = None,
    grid: str | None = None,
    velocity: str | bool | None = None,
    velocity_scale: float | str = "auto",
    velocity_time: str = "auto",
    **options: object,
) -> tuple[LevelSetSkin, str | bool | None]:
    """The skin skin_sequence advances over the VDB files of `pattern` for `frames`, and
    the velocity to hand each advance: the velocity's scale and timing measured over
    `frames` as the command does unless given (False when it does not explain the
    motion, with a warning). first_frame starts the skin later (a resumed bake, a farm
    chunk), measured over all of `frames` still. Needs HAS_VDB."""

def skin_sequence(
    pattern: str | PathLike[str],
    *,
    frames: tuple[int, int] | None = None,
    mesh: str | PathLike[str] | None = None,
    out: str | PathLike[str] | None = None,
    progress: Callable[[Mesh], object] | None = None,
    grid: str | None = None,
    velocity: str | bool | None = None,
    velocity_scale: float | str = "auto",
    velocity_time: str = "auto",
    voxel_size: float | None = None,
    alpha: float = ...,
    beta: float | None = None,
    fps: float = ...,
    velocities: bool = True,
    iso: float | None = None,
    units: str = "auto",
    init: Target | None = None,
) -> int:
    """The `skin` command as a function on VDB files (needs HAS_VDB): each frame's mesh
    written to the `mesh` pattern, its skin to the `out` VDB pattern, progress called
    after each frame; the velocity's scale and timing measured as the command measures
    them unless given. The command's frames, byte for byte."""

def measure_velocity(
    pattern: str | PathLike[str],
    *,
    frames: tuple[int, int] | None = None,
    grid: str | None = None,
    velocity: str | None = None,
    fps: float = ...,
    units: str = "auto",
    velocity_time: str | None = None,
) -> dict[str, object] | None:
    """The velocity's scale (world units per second per cache unit; None when it does not
    explain the surface's motion) and timing ("start" or "mid") as `skin` measures them,
    with the command's note; None when the files hold no velocity. Needs HAS_VDB."""
