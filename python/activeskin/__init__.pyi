from os import PathLike
from typing import Callable, Mapping, Sequence

import numpy as np
import numpy.typing as npt

__version__: str

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

class ParticleSkin:
    """A skin advanced one frame at a time by a particle simulation's particles."""

    def __init__(
        self,
        radius: float,
        *,
        voxel_size: float | None = None,
        alpha: float = 4.0,
        beta: float | None = None,
        smoothing_length: float = 2.0,
        iso: float | None = None,
        fps: float = 24.0,
        velocities: bool = True,
        hold_volume: bool = True,
        attributes: Sequence[str] | None = None,
        first_frame: int = 1,
        ignore_radii: bool = False,
        volume_reference: tuple[int, npt.ArrayLike, npt.ArrayLike | None] | None = None,
    ) -> None:
        """radius: half the particles' rest spacing; voxel_size defaults to radius/2;
        alpha (1/s) the attraction; beta (world units²/s) the surface tension, by default
        alpha·voxel²/8; attributes: names to carry onto the surface, or ["all"];
        volume_reference: (frame, positions, radii or None) of the sequence's first
        frame when the skin starts later (the volume those particles stand for is held,
        as the command holds it).
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
    alpha: float = 4.0,
    beta: float | None = None,
    smoothing_length: float = 2.0,
    iso: float | None = None,
    fps: float = 24.0,
    velocities: bool = True,
    hold_volume: bool = True,
    attributes: Sequence[str] | None = None,
) -> int:
    """The `particles` command as a function: the files of `pattern` (#### or %04d padded,
    # unpadded) over `frames`, each frame's mesh written to the `mesh` pattern, progress
    called after each frame. The command's meshes, byte for byte."""
