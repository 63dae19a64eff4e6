"""The Python package against the command line, with pytest: run by tests/python.rs
after it builds the wheel with maturin into a venv of its own.

    ACTIVESKIN_BIN=target/release/activeskin pytest python/tests
"""

import os
import pathlib
import subprocess
import tempfile
import threading
import time

import numpy as np
import pytest

import activeskin

R = 0.02
ROOT = pathlib.Path(__file__).resolve().parents[2]
SPLASH = ROOT / "data" / "splash"


@pytest.fixture(scope="session")
def binary():
    path = os.environ.get("ACTIVESKIN_BIN")
    if not path:
        pytest.fail("set ACTIVESKIN_BIN to the activeskin binary")
    return path


def ball(frame):
    """A ball of particles 2r apart moving along x and squashing a little, ids shuffled on
    odd frames, with temperature = 300 + 50 x (float32 values, as a PLY holds them)."""
    g = np.mgrid[-5:6, -5:6, -5:6].reshape(3, -1).T.astype(np.float32) * (2 * R)
    g = g[(g.astype(np.float64) ** 2).sum(1) <= (10 * R) ** 2 + 1e-9]
    squash = np.array([1, 1 - 0.02 * frame, 1], np.float32)
    p = (g * squash + np.array([0.03 * frame, 0, 0], np.float32)).astype(np.float32)
    ids = np.arange(len(p), dtype=np.int32)
    if frame % 2:
        p, ids = p[::-1].copy(), ids[::-1].copy()
    temperature = (300 + 50 * p[:, 0]).astype(np.float32)
    return p, ids, temperature


def write_ply(path, p, ids, temperature):
    rows = np.zeros(len(p), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<i4"),
                                   ("temperature", "<f4")])
    rows["x"], rows["y"], rows["z"] = p[:, 0], p[:, 1], p[:, 2]
    rows["id"], rows["temperature"] = ids, temperature
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(p)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property int id\nproperty float temperature\nend_header\n"
    )
    path.write_bytes(header.encode() + rows.tobytes())


def test_handed_arrays_make_the_commands_meshes(binary, tmp_path):
    data, cli, ours = tmp_path / "data", tmp_path / "cli", tmp_path / "ours"
    for d in (data, cli, ours):
        d.mkdir()
    frames = range(1, 5)
    for f in frames:
        write_ply(data / f"p.{f:04d}.ply", *ball(f))
    subprocess.run(
        [binary, "particles", "--particles", str(data / "p.####.ply"), "--radius", str(R),
         "--attribute", "temperature", "--mesh", str(cli / "m.####.ply"),
         "--usd", str(cli / "shot.usda"), "--up", "z", "--meters-per-unit", "0.01", "-q"],
        check=True,
    )
    skin = activeskin.ParticleSkin(R, attributes=["temperature"])
    assert skin.mesh is None and skin.stats is None
    for f in frames:
        p, ids, temperature = ball(f)
        # float64, Fortran order, int64 ids: converted once, to the same floats.
        mesh = skin.advance(np.asfortranarray(p.astype(np.float64)), ids=ids.astype(np.int64),
                            attributes={"temperature": temperature.astype(np.float64)})
        assert mesh.frame == f and skin.mesh is mesh and skin.stats["frame"] == f
        assert mesh.vertices.dtype == np.float32 and mesh.vertices.shape[1] == 3
        assert mesh.triangles.dtype == np.uint32 and mesh.triangles.max() < len(mesh.vertices)
        assert mesh.velocities is not None and mesh.velocities.shape == mesh.vertices.shape
        assert set(mesh.stats) >= {"frame", "time", "substeps", "band_nodes", "area", "volume",
                                   "euler_characteristic", "components"}
        assert mesh.stats["euler_characteristic"] == 2 and mesh.stats["components"] == 1
        t = mesh.attributes["temperature"]
        assert abs(t - (300 + 50 * mesh.vertices[:, 0])).mean() < 0.35
        mesh.save(ours / f"m.{f:04d}.ply")
        a, b = (ours / f"m.{f:04d}.ply").read_bytes(), (cli / f"m.{f:04d}.ply").read_bytes()
        assert a == b, f"frame {f}: the Python mesh differs from the command's"
        mesh.save_usd(ours / "shot.usda", (1, 4), up="z", meters_per_unit=0.01)
    # The USD shot too: stage, manifest and every frame's layer.
    written = sorted(p.relative_to(cli) for p in cli.rglob("*.usda"))
    assert len(written) == 2 + len(frames), written
    assert written == sorted(p.relative_to(ours) for p in ours.rglob("*.usda"))
    for name in written:
        assert (ours / name).read_bytes() == (cli / name).read_bytes(), name
    with pytest.raises(ValueError, match="not one of the shot's frames, 1-3"):
        mesh.save_usd(ours / "shot.usda", (1, 3))
    with pytest.raises(ValueError, match="name the stage .usda or .usd"):
        mesh.save_usd(ours / "shot.usdc", (1, 4))
    with pytest.raises(ValueError, match="up must be"):
        mesh.save_usd(ours / "shot.usda", (1, 4), up="x")


def test_the_demo_splash_read_and_skinned_in_python_is_the_commands(binary, tmp_path):
    """The drop-and-splash sample as the demo dresses it (α = 48), read with
    read_particles: the OBJ meshes byte for byte the command's."""
    cli, ours = tmp_path / "cli", tmp_path / "ours"
    ours.mkdir()
    subprocess.run(
        [binary, "particles", "--particles", str(SPLASH / "drop.####.ply"), "--radius", "0.04",
         "--alpha", "48", "--mesh", str(cli / "m.####.obj"), "-q"],
        check=True,
    )
    skin = activeskin.ParticleSkin(0.04, alpha=48)
    frames = sorted(int(p.name.split(".")[1]) for p in SPLASH.glob("drop.*.ply"))
    assert len(frames) == 36
    for f in frames:
        read = activeskin.read_particles(SPLASH / f"drop.{f:04d}.ply")
        assert read["positions"].dtype == np.float32
        mesh = skin.advance(read["positions"], velocities=read["velocities"], ids=read["ids"])
        mesh.save(ours / f"m.{f:04d}.obj")
        assert (ours / f"m.{f:04d}.obj").read_bytes() == (cli / f"m.{f:04d}.obj").read_bytes(), f


def test_region_is_the_commands(binary, tmp_path):
    """region= is the command's --region: the same cut meshes, byte for byte, velocities
    and attributes carried to the cut's vertices; a region that holds nothing raises."""
    data, cli = tmp_path / "data", tmp_path / "cli"
    for d in (data, cli):
        d.mkdir()
    # Open on the box's sides by design: tests/python.rs checks the meshes written here as
    # surfaces with a boundary.
    for d in (tmp_path, cli):
        (d / ".cut-to-region").write_bytes(b"")
    for f in range(1, 4):
        write_ply(data / f"p.{f:04d}.ply", *ball(f))
    subprocess.run(
        [binary, "particles", "--particles", str(data / "p.####.ply"), "--radius", str(R),
         "--region", "-1,-1,-1,0.05,1,0.06", "--attribute", "temperature",
         "--mesh", str(cli / "m.####.ply"), "-q"],
        check=True,
    )
    skin = activeskin.ParticleSkin(R, region=((-1, -1, -1), (0.05, 1, 0.06)),
                                   attributes=["temperature"])
    for f in range(1, 4):
        p, ids, temperature = ball(f)
        mesh = skin.advance(p, ids=ids, attributes={"temperature": temperature})
        assert mesh.vertices[:, 0].max() <= 0.05 and mesh.vertices[:, 2].max() <= 0.06
        assert np.isclose(mesh.vertices[:, 0].max(), 0.05)
        # Linear in x on the particles: close to it at the cut's vertices too.
        t = mesh.attributes["temperature"]
        assert np.abs(t - (300 + 50 * mesh.vertices[:, 0])).max() < 2.0
        mesh.save(tmp_path / "m.ply")
        assert (tmp_path / "m.ply").read_bytes() == (cli / f"m.{f:04d}.ply").read_bytes()
    with pytest.raises(ValueError, match="region= must be a box"):
        activeskin.ParticleSkin(R, region=((0, 0, 0), (0, 1, 1)))
    with pytest.raises(ValueError, match="region must be two corners"):
        activeskin.ParticleSkin(R, region=(0, 0, 0, 1, 1, 1))


def test_the_arrays_are_the_rust_buffers_handed_over():
    skin = activeskin.ParticleSkin(R, attributes=["all"])
    p, ids, temperature = ball(1)
    mesh = skin.advance(p, ids=ids, attributes={"temperature": temperature})
    arrays = [mesh.vertices, mesh.triangles, mesh.normals, mesh.velocities,
              mesh.attributes["temperature"]]
    for a in arrays:
        # Not copied into numpy's own memory: the Rust vector is the array's buffer,
        # kept alive by its base.
        assert not a.flags.owndata and type(a.base).__name__ == "PySliceContainer", a.base
        assert a.flags.c_contiguous
    bases = {id(a.base) for a in arrays}
    assert len(bases) == len(arrays), "arrays share one buffer"


def test_smooth_is_the_commands(binary, tmp_path):
    """smooth= is the command's --smooth: 0 makes its --smooth 0 meshes, unlike the
    default's; a negative one is refused."""
    data, cli = tmp_path / "data", tmp_path / "cli"
    for d in (data, cli):
        d.mkdir()
    for f in range(1, 4):
        write_ply(data / f"p.{f:04d}.ply", *ball(f))
    subprocess.run(
        [binary, "particles", "--particles", str(data / "p.####.ply"), "--radius", str(R),
         "--smooth", "0", "--mesh", str(cli / "m.####.ply"), "-q"],
        check=True,
    )
    plain, smoothed = activeskin.ParticleSkin(R, smooth=0), activeskin.ParticleSkin(R)
    for f in range(1, 4):
        p, ids, _ = ball(f)
        mesh, other = plain.advance(p, ids=ids), smoothed.advance(p, ids=ids)
        mesh.save(tmp_path / "m.ply")
        assert (tmp_path / "m.ply").read_bytes() == (cli / f"m.{f:04d}.ply").read_bytes()
        assert not np.array_equal(mesh.vertices, other.vertices)
    with pytest.raises(ValueError, match="smooth= must be a non-negative number"):
        activeskin.ParticleSkin(R, smooth=-1.0)


def test_bad_arguments_raise_value_error_naming_the_argument():
    """The library's words, each setting said as the argument that sets it (issue 50):
    never the command's flag."""
    for kwargs, text in [
        (dict(radius=-1.0), "radius= must be a positive number"),
        (dict(radius=R, voxel_size=1.0), "voxel_size= 1 is coarser than the particles' kernel"),
        (dict(radius=R, fps=0.0), "fps= must be a positive number"),
        (dict(radius=R, alpha=-1.0), "alpha= must be a non-negative number"),
        (dict(radius=R, smoothing_length=0.0), "smoothing_length= must be a positive number"),
    ]:
        with pytest.raises(ValueError, match=text.replace("(", r"\(")) as raised:
            activeskin.ParticleSkin(**kwargs)
        assert "--" not in str(raised.value), raised.value
    skin = activeskin.ParticleSkin(R, attributes=["age"])
    p, ids, _ = ball(1)
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        skin.advance(p[:, :2])
    with pytest.raises(ValueError, match="one per particle"):
        skin.advance(p, ids=ids[:5])
    with pytest.raises(ValueError, match="no particle attribute 'age'"):
        skin.advance(p, ids=ids)
    # Stopped by the error: said so, not a hang.
    with pytest.raises(RuntimeError, match="stopped"):
        skin.advance(p, ids=ids)
    with pytest.raises(ValueError):
        activeskin.read_particles(ROOT / "README.md")


def test_hostile_arrays_raise_and_the_skin_goes_on():
    """Issue 52: what the command refuses, advance() refuses with the argument named, before
    anything is sent to the skin (which then takes the next good frame); arrays too large
    for the memory budget raise MemoryError before they are copied, never abort."""
    skin = activeskin.ParticleSkin(R)
    p, ids, _ = ball(1)
    bad = lambda a, i, v: (a.__setitem__(i, v), a)[1]
    for kwargs, error, text in [
        (dict(positions=bad(p.copy(), (3, 1), np.nan)), ValueError, "positions: particle 3 has a NaN"),
        (dict(positions=np.full_like(p, np.inf)), ValueError, "positions: particle 0"),
        (dict(positions=p, radii=np.full(len(p), -R, np.float32)), ValueError, "radii: particle 0"),
        (dict(positions=p, velocities=bad(np.zeros_like(p), (2, 2), np.inf)), ValueError, "velocities: particle 2"),
        (dict(positions=p[:, :, None]), ValueError, "positions must be an (n, 3) array"),
        (dict(positions=[]), ValueError, "positions must be an (n, 3) array"),
        (dict(positions=None), ValueError, "positions must be an (n, 3) array"),
        (dict(positions=p, ids=None, radii=np.zeros((len(p), 2))), ValueError, "radii must be an"),
        (dict(positions=np.broadcast_to(np.zeros(3, np.float32), (2**31, 3))), MemoryError, "memory budget"),
    ]:
        with pytest.raises(error, match=text.replace("(", r"\(").replace(")", r"\)")):
            skin.advance(**kwargs)
    # An object array holding None: NaN once converted, refused as NaN.
    held = p.astype(object)
    held[5, 0] = None
    with pytest.raises(ValueError, match="positions: particle 5 has a NaN"):
        skin.advance(held)
    # A budget the caller sets: 150 M rows refused under 1 GB, allowed back after.
    activeskin.set_memory_budget(1.0)
    try:
        assert activeskin.memory_budget() == 1.0
        with pytest.raises(MemoryError, match="set_memory_budget"):
            skin.advance(np.broadcast_to(np.zeros(3, np.float32), (150_000_000, 3)))
    finally:
        activeskin.set_memory_budget(0)
    with pytest.raises(ValueError, match="non-negative"):
        activeskin.set_memory_budget(float("nan"))
    # The skin goes on with a good frame.
    mesh = skin.advance(p, ids=ids)
    assert len(mesh.triangles) > 0
    # Voxels too fine for 32-bit coordinates where the particles are: said, not an empty mesh.
    with pytest.raises(ValueError, match="larger voxel size"):
        activeskin.ParticleSkin(1e-9).advance(p + 0.5)
    # A radius whose voxels' areas overflow 32-bit floats: said, not blamed on beta.
    with pytest.raises(ValueError, match="beyond 1e15 world units"):
        activeskin.ParticleSkin(1e30)


def test_a_python_thread_keeps_running_while_a_frame_computes():
    counted = [0]
    stop = threading.Event()

    def count():
        while not stop.is_set():
            counted[0] += 1

    skin = activeskin.ParticleSkin(R / 2)
    p, _, _ = ball(1)
    p = np.concatenate([p, p + [0.5, 0, 0]])
    thread = threading.Thread(target=count)
    thread.start()
    start = time.perf_counter()
    skin.advance(p)
    seconds = time.perf_counter() - start
    during = counted[0]
    stop.set()
    thread.join()
    # Counting runs all along the frame (the GIL released), not only between calls.
    assert during > 1000, f"{during} counts in {seconds:.2f} s"


def test_particles_sequence_is_the_command_with_a_progress_callback(binary, tmp_path):
    cli = tmp_path / "cli"
    subprocess.run(
        [binary, "particles", "--particles", str(SPLASH / "drop.####.ply"), "--radius", "0.04",
         "--alpha", "48", "--frames", "3-20", "--mesh", str(cli / "m.####.ply"), "-q"],
        check=True,
    )
    seen = []
    count = activeskin.particles_sequence(
        SPLASH / "drop.####.ply", 0.04, alpha=48, frames=(3, 20),
        mesh=tmp_path / "py" / "m.%04d.ply", progress=lambda m: seen.append(m.frame),
    )
    assert count == 18 and seen == list(range(3, 21))
    for f in seen:
        assert (tmp_path / "py" / f"m.{f:04d}.ply").read_bytes() == (cli / f"m.{f:04d}.ply").read_bytes(), f
    # Every frame found when no range is given.
    assert activeskin.particles_sequence(SPLASH / "drop.####.ply", 0.04, alpha=48) == 36
    with pytest.raises(ValueError, match="no file matches pattern"):
        activeskin.particles_sequence(tmp_path / "none.####.ply", 0.04)


def test_sequences_and_defaults_are_the_librarys(binary, tmp_path):
    """Issue 50: patterns, frames found, the warm-up and the defaults come from the library,
    as the commands have them: $F4 and {} too, which the package's own parser lacked."""
    assert os.fspath(activeskin.frame_path("out/s.$F4.ply", 7)) == "out/s.0007.ply"
    assert os.fspath(activeskin.frame_path("p_{}.vtk", 12)) == "p_12.vtk"
    assert os.fspath(activeskin.frame_path("p_#.vtk", -3)) == "p_-3.vtk"
    first, last, found, held = activeskin.sequence_frames(SPLASH / "drop.$F4.ply")
    assert (first, last, found, held) == (1, 36, list(range(1, 37)), False)
    assert activeskin.sequence_frames(SPLASH / "drop.0002.ply", (5, 9))[:2] == (5, 9)
    assert activeskin.sequence_frames(SPLASH / "drop.0002.ply", (5, 9))[3]
    with pytest.raises(ValueError, match="is empty"):
        activeskin.sequence_frames(SPLASH / "drop.####.ply", (9, 5))
    with pytest.raises(ValueError, match="frames="):
        activeskin.sequence_frames(SPLASH / "drop.0002.ply")
    cli = tmp_path / "cli"
    subprocess.run(
        [binary, "particles", "--particles", str(SPLASH / "drop.####.ply"), "--radius", "0.04",
         "--alpha", "48", "--frames", "1-3", "--mesh", str(cli / "m.####.ply"), "-q"],
        check=True,
    )
    activeskin.particles_sequence(SPLASH / "drop.$F4.ply", 0.04, alpha=48, frames=(1, 3),
                                  mesh=tmp_path / "py" / "m.$F4.ply")
    for f in range(1, 4):
        assert (tmp_path / "py" / f"m.{f:04d}.ply").read_bytes() == (cli / f"m.{f:04d}.ply").read_bytes()
    assert activeskin.DEFAULT_ALPHA == 4.0 and activeskin.DEFAULT_FPS == 24.0
    assert activeskin.warmup_frames() == 23 and activeskin.warmup_frames(48.0, 24.0) == 2


# Level sets: LevelSetSkin and skin_sequence.

MOVING = ROOT / "data" / "moving"
needs_vdb = pytest.mark.skipif(not activeskin.HAS_VDB, reason="built without OpenVDB")


def dense(n, spacing, origin, f):
    """f at the centres of an (n, n, n) block of voxels, voxel (i, j, k) at
    origin + (i, j, k) * spacing."""
    axis = origin + spacing * np.arange(n)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    return f(x, y, z)


def test_a_dense_level_set_in_voxels_is_skinned_onto_its_sphere():
    spacing, origin = 0.05, -1.0
    center, radius = np.array([0.15, -0.1, 0.05]), 0.55
    # float64, Fortran order, distances in voxels as Mantaflow's phi, 43 voxels a side
    # (not whole leaves): converted once, measured and rescaled.
    phi = dense(43, spacing, origin, lambda x, y, z: (np.sqrt(
        (x - center[0]) ** 2 + (y - center[1]) ** 2 + (z - center[2]) ** 2) - radius) / spacing)
    phi = np.asfortranarray(phi)
    skin = activeskin.LevelSetSkin(spacing=spacing, origin=(origin,) * 3)
    for f in range(1, 13):
        mesh = skin.advance(phi)
        assert mesh.frame == f and mesh.stats["euler_characteristic"] == 2
    off = np.abs(np.linalg.norm(mesh.vertices - center, axis=1) - radius).mean() / spacing
    assert off < 0.1, f"{off} voxel from the sphere"
    assert mesh.velocities is not None and np.abs(mesh.velocities).max() < 0.05


def test_a_level_set_skin_cut_to_a_region_is_open_on_its_sides():
    """region= on LevelSetSkin: a sphere cut by the plane z = 0 is a hemisphere, its rim on
    the plane, its skin (area, volume) the whole sphere's."""
    spacing, origin = 0.05, -1.0
    phi = dense(40, spacing, origin, lambda x, y, z: np.sqrt(x * x + y * y + z * z) - 0.6)
    whole = activeskin.LevelSetSkin(spacing=spacing, origin=(origin,) * 3)
    cut = activeskin.LevelSetSkin(spacing=spacing, origin=(origin,) * 3,
                                  region=((-2, -2, 0), (2, 2, 2)))
    for _ in range(3):
        a, b = whole.advance(phi), cut.advance(phi)
    assert b.vertices[:, 2].min() == 0.0
    assert len(b.vertices) < 0.6 * len(a.vertices)
    assert b.stats["volume"] == a.stats["volume"] and b.stats["area"] == a.stats["area"]
    rim = b.vertices[b.vertices[:, 2] == 0.0]
    assert np.abs(np.linalg.norm(rim, axis=1) - 0.6).max() < 0.5 * spacing


def test_a_dense_morph_from_a_sphere_to_a_torus_ends_a_torus():
    spacing, origin, n = 0.04, -0.96, 48
    sphere = dense(n, spacing, origin, lambda x, y, z: np.sqrt(x * x + y * y + z * z) - 0.5)
    torus = dense(n, spacing, origin,
                  lambda x, y, z: np.sqrt((np.sqrt(x * x + y * y) - 0.55) ** 2 + z * z) - 0.2)
    skin = activeskin.LevelSetSkin(alpha=16, seed=False, init=sphere, spacing=spacing,
                                   origin=(origin,) * 3)
    first = skin.advance(torus)
    assert first.stats["euler_characteristic"] == 2, "frame 1 is the shape it starts on"
    for _ in range(2, 49):
        mesh = skin.advance(torus)
    assert mesh.frame == 48 and mesh.stats["euler_characteristic"] == 0


def test_a_dense_velocity_carries_the_skin():
    """A sphere gliding 2 voxels a frame along x, with its velocity: the skin keeps up."""
    spacing, origin, n, fps = 0.05, -1.0, 40, 24.0
    speed = 2 * spacing * fps
    skin = activeskin.LevelSetSkin(spacing=spacing, origin=(origin,) * 3, fps=fps)
    velocity = np.zeros((n, n, n, 3), np.float32)
    velocity[..., 0] = speed
    for f in range(1, 13):
        cx = -0.4 + speed * (f - 1) / fps
        phi = dense(n, spacing, origin,
                    lambda x, y, z: np.sqrt((x - cx) ** 2 + y * y + z * z) - 0.3)
        mesh = skin.advance(phi, velocity)
    lag = (mesh.vertices[:, 0].mean() - cx) / spacing
    assert abs(lag) < 0.1, f"{lag} voxel behind"
    assert abs(mesh.velocities[:, 0].mean() - speed) < 0.05 * speed


def test_level_set_errors_are_value_errors_with_the_commands_message(tmp_path):
    with pytest.raises(ValueError, match="velocity_time must be 'start' or 'mid'"):
        activeskin.LevelSetSkin(velocity_time="auto")
    with pytest.raises(ValueError, match="units must be"):
        activeskin.LevelSetSkin(units="inches")
    with pytest.raises(ValueError, match="fps= must be a positive number"):
        activeskin.LevelSetSkin(fps=-1)
    skin = activeskin.LevelSetSkin()
    with pytest.raises(ValueError, match="needs its voxel size: give spacing="):
        skin.advance(np.zeros((8, 8, 8)))
    skin = activeskin.LevelSetSkin(spacing=0.1)
    with pytest.raises(ValueError, match=r"must be \(nx, ny, nz\)"):
        skin.advance(np.zeros((8, 8)))
    with pytest.raises(ValueError, match=r"velocity must be \(8, 8, 8, 3\)"):
        skin.advance(np.zeros((8, 8, 8)), np.zeros((8, 8, 8)))
    phi = np.ones((8, 8, 8))
    phi[3, 3, 3] = np.nan
    with pytest.raises(ValueError, match="holds NaN or infinite values"):
        skin.advance(phi)
    with pytest.raises(RuntimeError, match="stopped"):
        skin.advance(phi)
    if not activeskin.HAS_VDB:
        with pytest.raises(RuntimeError, match="--features vdb"):
            activeskin.LevelSetSkin().advance(MOVING / "sphere.0001.vdb")
        with pytest.raises(RuntimeError, match="--features vdb"):
            activeskin.skin_sequence(MOVING / "sphere.####.vdb")
    else:
        with pytest.raises(ValueError, match="missing.vdb"):
            activeskin.LevelSetSkin().advance(tmp_path / "missing.vdb")


@needs_vdb
def test_a_vdb_morph_is_the_commands(binary, tmp_path):
    """A morph between two VDB files (written by save_vdb from numpy level sets), as
    LevelSetSkin(init=..., seed=False) and as `activeskin morph`: the same OBJ bytes."""
    spacing, origin, n = 0.04, -0.96, 48
    shapes = {
        "from": dense(n, spacing, origin, lambda x, y, z: np.sqrt(x * x + y * y + z * z) - 0.5),
        "to": dense(n, spacing, origin, lambda x, y, z: np.sqrt(
            (np.sqrt(x * x + y * y) - 0.55) ** 2 + z * z) - 0.2),
    }
    for name, phi in shapes.items():
        skin = activeskin.LevelSetSkin(spacing=spacing, origin=(origin,) * 3)
        skin.advance(phi)
        skin.save_vdb(tmp_path / f"{name}.vdb")
    cli, ours = tmp_path / "cli", tmp_path / "ours"
    ours.mkdir()
    subprocess.run(
        [binary, "morph", "--from", str(tmp_path / "from.vdb"), "--to", str(tmp_path / "to.vdb"),
         "--alpha", "16", "--frames", "1-30", "--mesh", str(cli / "m.####.obj"), "-q"],
        check=True,
    )
    skin = activeskin.LevelSetSkin(alpha=16, seed=False, init=tmp_path / "from.vdb")
    for f in range(1, 31):
        mesh = skin.advance(tmp_path / "to.vdb")
        mesh.save(ours / f"m.{f:04d}.obj")
        assert (ours / f"m.{f:04d}.obj").read_bytes() == (cli / f"m.{f:04d}.obj").read_bytes(), f
    assert mesh.stats["euler_characteristic"] == 0


@needs_vdb
def test_skin_sequence_is_the_skin_command(binary, tmp_path):
    cli = tmp_path / "cli"
    subprocess.run(
        [binary, "skin", "--target", str(MOVING / "sphere.####.vdb"), "--mesh",
         str(cli / "m.####.ply"), "-q"],
        check=True,
    )
    seen = []
    count = activeskin.skin_sequence(
        MOVING / "sphere.####.vdb", mesh=tmp_path / "py" / "m.####.ply",
        out=tmp_path / "vdb" / "s.####.vdb", progress=lambda m: seen.append(m.frame),
    )
    assert count == 8 and seen == list(range(1, 9))
    for f in seen:
        assert (tmp_path / "py" / f"m.{f:04d}.ply").read_bytes() == (cli / f"m.{f:04d}.ply").read_bytes(), f
        # The skins written are VDB level sets the command reads.
        info = subprocess.run([binary, "info", str(tmp_path / "vdb" / f"s.{f:04d}.vdb")],
                              capture_output=True, text=True, check=True).stdout
        assert "grid 'surface'" in info and "level set" in info and "grid 'v'" in info


@needs_vdb
def test_skin_sequence_measures_the_velocity_as_the_command_does(binary, tmp_path):
    """A sequence with a velocity grid (the command's own skins, which carry their
    surface's velocity as `v`): skin_sequence measures its scale and timing as `skin`
    does by default, and gives the command's meshes byte for byte."""
    subprocess.run(
        [binary, "skin", "--target", str(MOVING / "sphere.####.vdb"), "--out",
         str(tmp_path / "moving" / "s.####.vdb"), "-q"],
        check=True,
    )
    pattern = tmp_path / "moving" / "s.####.vdb"
    run = subprocess.run(
        [binary, "skin", "--target", str(pattern), "--mesh", str(tmp_path / "cli" / "m.####.ply")],
        check=True, capture_output=True, text=True,
    )
    measured = activeskin.measure_velocity(pattern)
    assert measured is not None and measured["scale"] is not None, measured
    # The command's note, its settings said as Python's arguments.
    assert "velocity_scale=, velocity_time= to override" in measured["note"], measured["note"]
    said = measured["note"].replace("velocity_scale=, velocity_time=", "--velocity-scale, --velocity-time")
    assert said in run.stderr, (measured["note"], run.stderr)
    assert activeskin.skin_sequence(pattern, mesh=tmp_path / "py" / "m.####.ply") == 8
    for f in range(1, 9):
        assert (tmp_path / "py" / f"m.{f:04d}.ply").read_bytes() == (tmp_path / "cli" / f"m.{f:04d}.ply").read_bytes(), f
    # Given, not measured: the command's frames with the same options.
    subprocess.run(
        [binary, "skin", "--target", str(pattern), "--velocity-scale", "1", "--velocity-time",
         "start", "--mesh", str(tmp_path / "cli1" / "m.####.ply"), "-q"],
        check=True,
    )
    activeskin.skin_sequence(pattern, mesh=tmp_path / "py1" / "m.####.ply", velocity_scale=1.0,
                             velocity_time="start")
    for f in range(1, 9):
        assert (tmp_path / "py1" / f"m.{f:04d}.ply").read_bytes() == (tmp_path / "cli1" / f"m.{f:04d}.ply").read_bytes(), f


def write_box_obj(path, lo, hi):
    """A closed box, outward, as an OBJ mesh."""
    corners = [[hi[a] if c >> a & 1 else lo[a] for a in range(3)] for c in range(8)]
    quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
    lines = ["v %r %r %r" % tuple(c) for c in corners]
    for a, b, c, d in quads:
        lines += [f"f {a + 1} {b + 1} {c + 1}", f"f {a + 1} {c + 1} {d + 1}"]
    path.write_text("\n".join(lines) + "\n")


def test_collider_is_the_commands(binary, tmp_path):
    """collider= is the command's --collider: the ball meets the floor under it, with the
    command's meshes byte for byte; bad colliders raise with the argument named."""
    data, cli = tmp_path / "data", tmp_path / "cli"
    for d in (data, cli):
        d.mkdir()
    floor = tmp_path / "floor.obj"
    write_box_obj(floor, (-1, -1, -1), (1, -0.23, 1))
    for f in range(1, 4):
        write_ply(data / f"p.{f:04d}.ply", *ball(f))
    subprocess.run(
        [binary, "particles", "--particles", str(data / "p.####.ply"), "--radius", str(R),
         "--collider", str(floor), "--collider-depth", "0.005",
         "--mesh", str(cli / "m.####.ply"), "-q"],
        check=True,
    )
    met = activeskin.ParticleSkin(R, collider=floor, collider_depth=0.005)
    plain = activeskin.ParticleSkin(R)
    for f in range(1, 4):
        p, ids, _ = ball(f)
        mesh, free = met.advance(p, ids=ids), plain.advance(p, ids=ids)
        # Down to the floor and 0.005 into it, where the free ball stops short of it.
        assert abs(mesh.vertices[:, 1].min() + 0.235) < 0.25 * R, mesh.vertices[:, 1].min()
        assert free.vertices[:, 1].min() > -0.23 + 0.25 * R
        assert mesh.stats["volume"] == free.stats["volume"]
        mesh.save(tmp_path / "m.ply")
        assert (tmp_path / "m.ply").read_bytes() == (cli / f"m.{f:04d}.ply").read_bytes()
    with pytest.raises(ValueError, match="collider= '.*floor.stl': a collider is a VDB"):
        activeskin.ParticleSkin(R, collider=tmp_path / "floor.stl")
    with pytest.raises(ValueError, match="collider_gap= must be a number of world units"):
        activeskin.ParticleSkin(R, collider=floor, collider_gap=-1)
    missing = activeskin.ParticleSkin(R, collider=tmp_path / "none.####.obj")
    with pytest.raises(ValueError, match="none.0001.obj"):
        missing.advance(ball(1)[0])


def test_a_level_set_skin_meets_a_collider():
    """collider= on LevelSetSkin: a sphere 0.1 over a floor is carried down onto it (its
    gap 0.15), its skin (area, volume) the free sphere's."""
    spacing, origin = 0.05, -1.0
    phi = dense(40, spacing, origin, lambda x, y, z: np.sqrt(x * x + y * y + z * z) - 0.6)
    with tempfile.TemporaryDirectory() as d:
        floor = pathlib.Path(d) / "floor.obj"
        write_box_obj(floor, (-2, -2, -2), (2, 2, -0.7))
        free = activeskin.LevelSetSkin(spacing=spacing, origin=(origin,) * 3)
        met = activeskin.LevelSetSkin(spacing=spacing, origin=(origin,) * 3,
                                      collider=floor, collider_gap=0.15)
        for _ in range(3):
            a, b = free.advance(phi), met.advance(phi)
    assert abs(a.vertices[:, 2].min() + 0.6) < 0.2 * spacing
    assert abs(b.vertices[:, 2].min() + 0.7) < 0.2 * spacing
    assert b.stats["volume"] == a.stats["volume"] and b.stats["area"] == a.stats["area"]
