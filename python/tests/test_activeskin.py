"""The Python package against the command line: run by tests/python.rs after building
the wheel with maturin into a venv of its own.

    python test_activeskin.py ACTIVESKIN_BINARY SCRATCH_DIR
"""

import pathlib
import subprocess
import sys
import threading
import time

import numpy as np

import activeskin

R = 0.02


def ball(frame):
    """A ball of particles 2r apart moving along x and squashing a little, ids shuffled on
    odd frames, with temperature = 300 + 50 x (float32 values, as a PLY holds them)."""
    g = np.mgrid[-5:6, -5:6, -5:6].reshape(3, -1).T.astype(np.float32) * (2 * R)
    g = g[(g.astype(np.float64) ** 2).sum(1) <= (10 * R) ** 2 + 1e-9]
    p = (g * np.array([1, 1 - 0.02 * frame, 1], np.float32) + np.array([0.03 * frame, 0, 0], np.float32)).astype(np.float32)
    ids = np.arange(len(p), dtype=np.int32)
    if frame % 2:
        p, ids = p[::-1].copy(), ids[::-1].copy()
    temperature = (300 + 50 * p[:, 0]).astype(np.float32)
    return p, ids, temperature


def write_ply(path, p, ids, temperature):
    rows = np.zeros(len(p), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<i4"), ("temperature", "<f4")])
    rows["x"], rows["y"], rows["z"] = p[:, 0], p[:, 1], p[:, 2]
    rows["id"], rows["temperature"] = ids, temperature
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(p)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property int id\nproperty float temperature\nend_header\n"
    )
    path.write_bytes(header.encode() + rows.tobytes())


def same_meshes_as_the_command(binary, scratch):
    data, cli, ours = scratch / "data", scratch / "cli", scratch / "ours"
    for d in (data, cli, ours):
        d.mkdir(parents=True, exist_ok=True)
    frames = range(1, 5)
    for f in frames:
        write_ply(data / f"p.{f:04d}.ply", *ball(f))
    subprocess.run(
        [binary, "particles", "--particles", str(data / "p.####.ply"), "--radius", str(R),
         "--attribute", "temperature", "--mesh", str(cli / "m.####.ply"), "-q"],
        check=True,
    )
    skin = activeskin.ParticleSkin(R, attributes=["temperature"])
    for f in frames:
        p, ids, temperature = ball(f)
        # float64, Fortran order, int64 ids: converted once, to the same floats.
        mesh = skin.advance(np.asfortranarray(p.astype(np.float64)), ids=ids.astype(np.int64),
                            attributes={"temperature": temperature.astype(np.float64)})
        assert mesh.frame == f
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
    print(f"same meshes as the command on {len(frames)} frames")


def bad_arguments_raise_value_error():
    for kwargs, text in [
        (dict(radius=-1.0), "--radius must be a positive number"),
        (dict(radius=R, voxel_size=1.0), "coarser than the particles' kernel"),
        (dict(radius=R, fps=0.0), "frame rate must be a positive number"),
    ]:
        try:
            activeskin.ParticleSkin(**kwargs)
        except ValueError as e:
            assert text in str(e), str(e)
        else:
            raise AssertionError(f"{kwargs} accepted")
    skin = activeskin.ParticleSkin(R, attributes=["age"])
    p, ids, _ = ball(1)
    for call, text in [
        (lambda: skin.advance(p[:, :2]), "(n, 3)"),
        (lambda: skin.advance(p, ids=ids[:5]), "one per particle"),
        (lambda: skin.advance(p, ids=ids), "no particle attribute 'age'"),
    ]:
        try:
            call()
        except ValueError as e:
            assert text in str(e), str(e)
        else:
            raise AssertionError(f"accepted: {text}")
    print("bad arguments raise ValueError")


def the_gil_is_released_while_a_frame_computes():
    counted = [0]
    stop = threading.Event()

    def count():
        while not stop.is_set():
            counted[0] += 1

    skin = activeskin.ParticleSkin(R / 2)
    p, ids, _ = ball(1)
    p = np.concatenate([p, p + [0.5, 0, 0]]) / 1.0
    thread = threading.Thread(target=count)
    thread.start()
    start = time.perf_counter()
    skin.advance(p)
    seconds = time.perf_counter() - start
    before = counted[0]
    stop.set()
    thread.join()
    # Counting runs all along the frame (the GIL released), not only between calls.
    assert before > 1000, f"{before} counts in {seconds:.2f} s"
    print(f"GIL released: {before} counts while a {seconds:.2f} s frame computed")


if __name__ == "__main__":
    binary, scratch = sys.argv[1], pathlib.Path(sys.argv[2])
    same_meshes_as_the_command(binary, scratch)
    bad_arguments_raise_value_error()
    the_gil_is_released_while_a_frame_computes()
