"""Active implicit skins (Desbrun & Cani 1997) on particle simulations and level sets.

A skin follows its target frame by frame, through the same frame loops as the commands:
``ParticleSkin`` as ``activeskin particles``, ``LevelSetSkin`` as ``activeskin skin`` (and
``morph``). The same inputs and parameters give the same surfaces, byte for byte.

>>> import numpy as np, activeskin
>>> skin = activeskin.ParticleSkin(radius=0.02, fps=24)
>>> mesh = skin.advance(np.random.rand(5000, 3) * 0.4)
>>> mesh.vertices.shape[1], mesh.triangles.dtype
(3, dtype('uint32'))
"""

import os
import warnings

from ._activeskin import (
    DEFAULT_ALPHA,
    DEFAULT_FPS,
    DEFAULT_PARTICLE_SMOOTHING,
    HAS_VDB,
    LevelSetSkin,
    Mesh,
    ParticleSkin,
    __version__,
    frame_path,
    memory_budget,
    read_particles,
    sequence_frames,
    set_memory_budget,
    warmup_frames,
    particle_voxel_size,
)

if HAS_VDB:
    from ._activeskin import measure_velocity  # noqa: F401

__all__ = [
    "DEFAULT_ALPHA",
    "DEFAULT_FPS",
    "DEFAULT_PARTICLE_SMOOTHING",
    "HAS_VDB",
    "LevelSetSkin",
    "Mesh",
    "ParticleSkin",
    "__version__",
    "frame_path",
    "memory_budget",
    "particles_sequence",
    "read_particles",
    "sequence_frames",
    "set_memory_budget",
    "skin_for_sequence",
    "skin_sequence",
    "warmup_frames",
    "particle_voxel_size",
] + (["measure_velocity"] if HAS_VDB else [])


def _frames(pattern, frames):
    """The range, the frames found and each frame's file, as the commands find them: the
    library's patterns (``####``, ``%04d``, ``$F4``, ``$F``, ``#``, ``{}``), or one file
    held for every frame of ``frames``."""
    first, last, found, held = sequence_frames(pattern, frames)
    if held:
        return first, last, found, lambda frame: os.fspath(pattern)
    return first, last, found, lambda frame: frame_path(pattern, frame)


def _make_folders(first, *patterns):
    for pattern in patterns:
        if pattern is not None:
            folder = os.path.dirname(frame_path(pattern, first))
            if folder:
                os.makedirs(folder, exist_ok=True)


def particles_sequence(pattern, radius, *, frames=None, mesh=None, progress=None,
                       use_velocity=True, **options):
    """The ``particles`` command as a function: skins the particle files of ``pattern``
    (``####``, ``%04d`` or ``$F4`` padded frame numbers, ``#`` or ``$F`` unpadded as
    SPlisHSPlasH writes) over
    ``frames`` (first, last; every frame found by default), writing each frame's mesh to
    the ``mesh`` pattern (OBJ or PLY by extension) when given, and calling
    ``progress(mesh)`` after each frame. ``options`` are ``ParticleSkin``'s (voxel_size,
    alpha, beta, fps, attributes, ...). Returns the number of frames skinned; the meshes
    are the command's, byte for byte.
    """
    first, last, found, path = _frames(pattern, frames)
    _make_folders(first, mesh)
    # The command holds the volume the sequence's first frame stands for, also on a run
    # of later frames.
    if found and found[0] < first and options.get("hold_volume", True):
        start = read_particles(path(found[0]))
        options["volume_reference"] = (found[0], start["positions"], start["radii"])
    skin = ParticleSkin(radius, first_frame=first, **options)
    count = 0
    for frame in range(first, last + 1):
        read = read_particles(path(frame))
        surface = skin.advance(
            read["positions"],
            velocities=read["velocities"] if use_velocity else None,
            ids=read["ids"] if use_velocity else None,
            attributes=read["attributes"] if skin.attributes else None,
            radii=read["radii"],
        )
        if mesh is not None:
            surface.save(frame_path(mesh, frame))
        if progress is not None:
            progress(surface)
        count += 1
    return count


def _need_vdb():
    if not HAS_VDB:
        raise RuntimeError(
            "this activeskin was built without OpenVDB: build the wheel with "
            "`maturin build --release --features vdb` to read VDB files"
        )


def skin_for_sequence(pattern, *, frames, first_frame=None, grid=None, velocity=None,
                      velocity_scale="auto", velocity_time="auto", **options):
    """The skin ``skin_sequence`` advances over the VDB files of ``pattern`` for ``frames``
    (first, last), and the ``velocity`` to hand each of its ``advance`` calls: the
    velocity's scale and timing measured over ``frames`` as the command measures them
    unless given (a velocity that does not explain the motion is left out, with a
    warning, and the velocity returned is False). ``first_frame`` (``frames``' first by
    default) starts the skin later, as a resumed bake or a farm chunk does, with the
    measure still made over all of ``frames``. Needs HAS_VDB."""
    _need_vdb()
    first, last = frames
    timing = None if velocity_time == "auto" else velocity_time
    if velocity is not False and velocity_scale == "auto":
        measured = measure_velocity(
            pattern, frames=(first, last), grid=grid,
            velocity=velocity if isinstance(velocity, str) else None,
            fps=options.get("fps", DEFAULT_FPS), units=options.get("units", "auto"),
            velocity_time=timing,
        )
        velocity_scale = 1.0
        if measured is not None:
            if measured["scale"] is None:
                warnings.warn(measured["note"], stacklevel=3)
                velocity = False
            else:
                velocity_scale = measured["scale"]
            timing = measured["timing"]
    elif velocity_scale == "auto":
        velocity_scale = 1.0
    skin = LevelSetSkin(first_frame=first if first_frame is None else first_frame,
                        velocity_scale=velocity_scale, velocity_time=timing or "start",
                        grid=grid, **options)
    return skin, velocity


def skin_sequence(pattern, *, frames=None, mesh=None, out=None, progress=None, grid=None,
                  velocity=None, velocity_scale="auto", velocity_time="auto", **options):
    """The ``skin`` command as a function: skins the VDB files of ``pattern`` (level sets,
    or fog volumes with ``iso=``; their ``grid``, else ``surface`` or ``phi``, else the first float grid) over
    ``frames`` (first, last; every frame found by default), carried by each file's
    velocity (``velocity``: None for its ``vel``, ``v`` or ``velocity`` grid, False for
    none, or a grid's name), writing each frame's mesh to the ``mesh`` pattern and its
    skin to the ``out`` VDB pattern when given, and calling ``progress(mesh)`` after each
    frame. As the command, ``velocity_scale`` and ``velocity_time`` are measured from the
    surface's own motion unless given ("auto"; a velocity that does not explain the
    motion is left out, with a warning). ``options`` are ``LevelSetSkin``'s (voxel_size,
    alpha, beta, fps, units, init, ...). Returns the number of frames skinned: the
    command's frames, byte for byte. Needs a build with OpenVDB (``HAS_VDB``).
    """
    _need_vdb()
    first, last, found, path = _frames(pattern, frames)
    _make_folders(first, mesh, out)
    # The VDBs written hold the surface's velocity as grid v, as the command's --out.
    options.setdefault("velocity_grid", out is not None)
    skin, velocity = skin_for_sequence(
        pattern, frames=(first, last), grid=grid, velocity=velocity,
        velocity_scale=velocity_scale, velocity_time=velocity_time, **options,
    )
    count = 0
    for frame in range(first, last + 1):
        surface = skin.advance(path(frame), velocity, grid=grid)
        if mesh is not None:
            surface.save(frame_path(mesh, frame))
        if out is not None:
            skin.save_vdb(frame_path(out, frame))
        if progress is not None:
            progress(surface)
        count += 1
    return count
