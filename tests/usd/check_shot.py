"""Reads an activeskin USD shot with Pixar's own library (usd-core) and checks it.

    python check_shot.py STAGE OBJ_PATTERN EXPECTED_JSON

Every time code of the stage is read through UsdGeom.Mesh and compared with the OBJ of
the same frame (OBJ_PATTERN with {frame:04d}): vertex and triangle counts equal,
positions within 1e-6, the same triangles. EXPECTED_JSON gives the stage metadata
(upAxis, metersPerUnit, timeCodesPerSecond, start, end) and the primvars expected.
Every registered UsdValidation validator runs on the stage; none may report an error.
Prints one JSON line of what was measured; exits 1 on the first failed check.
"""

import json
import sys

from pxr import Gf, Usd, UsdGeom, UsdValidation


def fail(message):
    print(f"check_shot: {message}", file=sys.stderr)
    sys.exit(1)


def read_obj(path):
    points, triangles = [], []
    with open(path) as f:
        for line in f:
            words = line.split()
            if not words:
                continue
            if words[0] == "v":
                points.append(tuple(float(w) for w in words[1:4]))
            elif words[0] == "f":
                triangles.append(tuple(int(w.split("/")[0]) - 1 for w in words[1:4]))
    return points, triangles


def main():
    stage_path, obj_pattern, expected = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
    stage = Usd.Stage.Open(stage_path)
    if stage is None:
        fail(f"{stage_path}: cannot open")
    got = {
        "upAxis": UsdGeom.GetStageUpAxis(stage),
        "metersPerUnit": UsdGeom.GetStageMetersPerUnit(stage),
        "timeCodesPerSecond": stage.GetTimeCodesPerSecond(),
        "framesPerSecond": stage.GetFramesPerSecond(),
        "start": stage.GetStartTimeCode(),
        "end": stage.GetEndTimeCode(),
    }
    for key in ("upAxis", "metersPerUnit", "timeCodesPerSecond", "framesPerSecond", "start", "end"):
        if got[key] != expected[key]:
            fail(f"{key} is {got[key]}, expected {expected[key]}")
    prim = stage.GetDefaultPrim()
    meshes = [p for p in Usd.PrimRange(prim) if p.IsA(UsdGeom.Mesh)]
    if len(meshes) != 1:
        fail(f"{len(meshes)} meshes under the default prim, expected 1")
    mesh = UsdGeom.Mesh(meshes[0])
    if mesh.GetSubdivisionSchemeAttr().Get() != "none":
        fail("the mesh is a subdivision surface")
    if mesh.GetNormalsInterpolation() != "vertex":
        fail(f"normals interpolation {mesh.GetNormalsInterpolation()}")
    samples = mesh.GetPointsAttr().GetTimeSamples()
    frames = list(range(int(expected["start"]), int(expected["end"]) + 1))
    if [int(t) for t in samples] != frames or any(t != int(t) for t in samples):
        fail(f"points sampled at {samples}, expected {frames}")
    api = UsdGeom.PrimvarsAPI(mesh)
    worst, vertices, attribute_error = 0.0, 0, 0.0
    for frame in frames:
        points = mesh.GetPointsAttr().Get(frame)
        counts = mesh.GetFaceVertexCountsAttr().Get(frame)
        indices = mesh.GetFaceVertexIndicesAttr().Get(frame)
        normals = mesh.GetNormalsAttr().Get(frame)
        obj_points, obj_triangles = read_obj(obj_pattern.format(frame=frame))
        if len(points) != len(obj_points) or len(counts) != len(obj_triangles):
            fail(
                f"frame {frame}: {len(points)} points, {len(counts)} faces; "
                f"the OBJ has {len(obj_points)}, {len(obj_triangles)}"
            )
        if set(counts) - {3}:
            fail(f"frame {frame}: faces of {set(counts)} vertices")
        if list(indices) != [i for t in obj_triangles for i in t]:
            fail(f"frame {frame}: the triangles differ from the OBJ's")
        if len(normals) != len(points):
            fail(f"frame {frame}: {len(normals)} normals for {len(points)} points")
        for p, q in zip(points, obj_points):
            worst = max(worst, abs(p[0] - q[0]), abs(p[1] - q[1]), abs(p[2] - q[2]))
        lo, hi = Gf.Vec3f(*map(min, zip(*points))), Gf.Vec3f(*map(max, zip(*points)))
        extent = mesh.GetExtentAttr().Get(frame)
        if extent is None or extent[0] != lo or extent[1] != hi:
            fail(f"frame {frame}: extent {extent}, the points span {lo} to {hi}")
        if expected.get("velocities"):
            v = mesh.GetVelocitiesAttr().Get(frame)
            if v is None or len(v) != len(points):
                fail(f"frame {frame}: no velocity per point")
        for name, kind in expected.get("primvars", {}).items():
            primvar = api.GetPrimvar(name)
            if not primvar or primvar.GetInterpolation() != "vertex":
                fail(f"frame {frame}: no vertex primvar {name}")
            values = primvar.Get(frame)
            if values is None or len(values) != len(points):
                fail(f"frame {frame}: primvar {name} has no value per point")
            if kind == "x":
                # The attribute was the particles' x: compared with the vertices' own,
                # as a fraction of the surface's extent along x.
                span = hi[0] - lo[0]
                mean = sum(abs(a - p[0]) for a, p in zip(values, points)) / len(points)
                attribute_error = max(attribute_error, mean / span)
        vertices += len(points)
    if worst > 1e-6:
        fail(f"positions differ from the OBJs' by up to {worst}")

    registry = UsdValidation.ValidationRegistry()
    validators = registry.GetOrLoadAllValidators()
    errors = UsdValidation.ValidationContext(validators).Validate(stage)
    serious = [e for e in errors if e.GetType() in (UsdValidation.ValidationErrorType.Error,)]
    if serious:
        fail("; ".join(f"{e.GetName()}: {e.GetMessage()}" for e in serious))
    print(
        json.dumps(
            {
                "frames": len(frames),
                "vertices": vertices,
                "worst_position": worst,
                "attribute_error": attribute_error,
                "validators": len(validators),
                "issues": [f"{e.GetName()}: {e.GetMessage()}" for e in errors],
            }
        )
    )


main()
