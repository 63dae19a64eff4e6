#!/usr/bin/env python3
"""Bakes a SPlisHSPlasH dam break into a particle cache, once: the moving SPH data of
`activeskin bench --particles` (and of anyone who wants to try the skin on a real liquid).

    python3 data/sph/bake_dam_break.py OUT_DIR [--frames 36] [--radius 0.005]
                                               [--scene dam_break|double_dam_break]

A column of water 0.32 x 0.52 x 0.35 m (about 52 k particles of radius 0.005, DFSPH,
SPlisHSPlasH's own defaults otherwise) collapses in a tank 0.9 m long, runs along the
floor at up to 5.6 m/s (47 voxels a frame at cell = radius, 24 fps), climbs the far wall
and falls back as a sheet with splashes.

`--scene double_dam_break`, the second scene the look is judged on: two columns of water
0.25 x 0.45 x 0.25 m (about 51 k particles) in opposite corners of a tank 0.8 x 0.8 m
collapse, meet along the diagonal and throw up a thin sheet that tears into droplets,
then the pool sloshes. Its frames are `OUT_DIR/double_dam_break_k.ply`.

Each frame k (k = 1 at t = 0, exactly k-1 / fps: the
solver's step is cut to land on it) is written as `OUT_DIR/dam_break_k.ply`, unpadded as
SPlisHSPlasH numbers its exports: binary little-endian PLY with x y z, vx vy vz (m/s) and
the particle's id, particles in id order (the same order every frame). A `done` file
marks a finished cache; the bake takes a few minutes on two cores.

Needs `pip install pysplishsplash numpy`. Its GUI library wants libGLdispatch loaded
first (preloaded below), and OMP_WAIT_POLICY=PASSIVE keeps OpenMP's idle threads off the
cores it shares with the caller.
"""

import argparse
import ctypes
import json
import os
import shutil
import sys
import tempfile

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


def scene(radius, name):
    """The scene `name`: the dam break (tank [0, 0.9] x [0, 0.6] x [0, 0.35], water at
    x < 0.32) or the double dam break (tank [0, 0.8] x [0, 0.7] x [0, 0.8], water in the
    corners x, z < 0.25 and x, z > 0.55)."""
    if name == "double_dam_break":
        tank, columns = [0.8, 0.7, 0.8], [
            ([radius, radius, radius], [0.25, 0.45, 0.25]),
            # The first column mirrored: SPlisHSPlasH fills a block from a spacing past
            # its start, so a block ending a radius short of a wall puts its last layer
            # 2r from it, and the volume map's pressure there blows the column apart.
            ([0.55 - radius, radius, 0.55 - radius], [0.8 - 2 * radius, 0.45, 0.8 - 2 * radius]),
        ]
    else:
        tank, columns = [0.9, 0.6, 0.35], [
            ([radius, radius, radius], [0.32, 0.52, 0.35 - radius]),
        ]
    return {
        "Configuration": {
            "particleRadius": radius,
            "simulationMethod": 4,  # DFSPH
            "gravitation": [0, -9.81, 0],
            "timeStepSize": 0.001,
            "cflMethod": 1,
            "cflFactor": 0.6,
            "cflMaxTimeStepSize": 0.004,
            "boundaryHandlingMethod": 2,  # volume maps (Bender 2019)
            "enableZSort": False,
            "DFSPH": {
                "minIterations": 2,
                "maxIterations": 100,
                "maxError": 0.05,
                "maxIterationsV": 100,
                "maxErrorV": 0.1,
                "enableDivergenceSolver": True,
            },
        },
        "Materials": [
            {
                "id": "Fluid",
                "density0": 1000,
                "viscosityMethod": 1,
                "Standard viscosity": {"viscosity": 0.01},
            }
        ],
        "RigidBodies": [
            {
                "geometryFile": "UNITBOX",
                "translation": [t / 2 for t in tank],
                "scale": tank,
                "isDynamic": False,
                "isWall": True,
                "mapInvert": True,
                "mapThickness": 0.0,
                "mapResolution": [round(50 * t) for t in tank],
            }
        ],
        "FluidBlocks": [
            {"denseMode": 0, "start": start, "end": end} for start, end in columns
        ],
    }


def write_ply(path, ids, x, v, name):
    import numpy as np

    n = len(ids)
    record = np.dtype(
        [("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
         ("vx", "<f4"), ("vy", "<f4"), ("vz", "<f4"), ("id", "<i4")]
    )
    data = np.empty(n, dtype=record)
    for k, name in enumerate("xyz"):
        data[name] = x[:, k]
        data["v" + name] = v[:, k]
    data["id"] = ids
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"comment SPlisHSPlasH {name.replace('_', ' ')} (activeskin data/sph/bake_dam_break.py)\n"
        f"element vertex {n}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float vx\nproperty float vy\nproperty float vz\n"
        "property int id\nend_header\n"
    )
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(data.tobytes())
    os.replace(tmp, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out")
    parser.add_argument("--frames", type=int, default=36)
    parser.add_argument("--fps", type=float, default=24.0)
    parser.add_argument("--radius", type=float, default=0.005)
    parser.add_argument("--scene", choices=["dam_break", "double_dam_break"],
                        default="dam_break")
    args = parser.parse_args()

    try:
        ctypes.CDLL("libGLdispatch.so.0", mode=ctypes.RTLD_GLOBAL)
    except OSError:
        pass
    try:
        import numpy as np
        import pysplishsplash as sph
    except ImportError as e:
        sys.exit(f"bake_dam_break: {e}: pip install pysplishsplash numpy")

    os.makedirs(args.out, exist_ok=True)
    work = tempfile.mkdtemp(prefix="activeskin-sph-")
    # The box's model ships with the package's data; the scene names it by path.
    models = os.path.join(os.path.dirname(sys.executable), "data", "models")
    box = os.path.join(models, "UnitBox.obj")
    if not os.path.isfile(box):
        box = os.path.join(work, "UnitBox.obj")
        with open(box, "w") as f:
            f.write(UNIT_BOX)
    description = scene(args.radius, args.scene)
    description["RigidBodies"][0]["geometryFile"] = box
    scene_file = os.path.join(work, args.scene + ".json")
    with open(scene_file, "w") as f:
        json.dump(description, f, indent=1)

    base = sph.Exec.SimulatorBase()
    last = (args.frames - 1) / args.fps
    base.init(useGui=False, outputDir=work, sceneFile=scene_file, stopAt=last + 1e-6)
    frame = 1

    def write(frame, start=False):
        fluid = sph.Simulation.getCurrent().getFluidModel(0)
        n = fluid.numActiveParticles()
        ids = np.array([fluid.getParticleId(i) for i in range(n)], dtype=np.int64)
        at = fluid.getPosition0 if start else fluid.getPosition
        x = np.array([at(i) for i in range(n)], dtype=np.float32)
        if start:
            v = np.zeros_like(x)
        else:
            v = np.array([fluid.getVelocity(i) for i in range(n)], dtype=np.float32)
        order = np.argsort(ids)
        write_ply(os.path.join(args.out, f"{args.scene}_{frame}.ply"),
                  ids[order].astype(np.int32), x[order], v[order], args.scene)
        speed = np.linalg.norm(v, axis=1)
        print(f"frame {frame}: {n} particles, speed max {speed.max():.2f} m/s, "
              f"mean {speed.mean():.2f}", flush=True)
        return n

    count = [0]

    def after_step():
        nonlocal frame
        tm = sph.TimeManager.getCurrent()
        if frame == 1:
            count[0] = write(1, start=True)
            frame = 2
        t = tm.getTime()
        end = (frame - 1) / args.fps
        if t >= end - 1e-7 and frame <= args.frames:
            write(frame)
            frame += 1
            end = (frame - 1) / args.fps
        # Cut the next step (the CFL has just chosen it) to land on the next frame.
        left = end - t
        if 0 < left < tm.getTimeStepSize():
            tm.setTimeStepSize(left)

    base.setTimeStepCB(after_step)
    base.run()
    n = count[0]
    with open(os.path.join(args.out, "done"), "w") as f:
        f.write(json.dumps({"scene": args.scene, "frames": args.frames, "fps": args.fps,
                            "radius": args.radius, "particles": n}) + "\n")
    # SimulatorBase.cleanup() crashes in these bindings; nothing is left to release but
    # the scene and the boundary's volume map.
    shutil.rmtree(work, ignore_errors=True)
    sys.stdout.flush()
    os._exit(0)


UNIT_BOX = """v -0.5 -0.5 -0.5
v 0.5 -0.5 -0.5
v 0.5 0.5 -0.5
v -0.5 0.5 -0.5
v -0.5 -0.5 0.5
v 0.5 -0.5 0.5
v 0.5 0.5 0.5
v -0.5 0.5 0.5
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 4 8 7
f 4 7 3
f 1 5 8
f 1 8 4
f 2 3 7
f 2 7 6
"""

if __name__ == "__main__":
    main()
