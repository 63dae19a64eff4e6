"""Writes one frame of N particles (positions, velocities, ids; default 1 M) in every
particle format activeskin reads, each as the tool that writes it in practice would:
legacy VTK binary and VTK XML (appended raw, ParaView's zlib and base64 inline) through
VTK's own writers, binary PLY, classic BGEO as partio writes it (gzipped), splashsurf's
JSON and a CSV with a header. For `activeskin bench --formats`, which times reading them.

    pip install vtk numpy
    python3 data/formats/write_frames.py OUTDIR [N]
"""
import gzip
import json
import os
import sys

import numpy as np
import vtk
from vtk.util import numpy_support

out = sys.argv[1]
n = int(sys.argv[2]) if len(sys.argv) > 2 else 1_000_000
os.makedirs(out, exist_ok=True)
rng = np.random.default_rng(7)
p = rng.random((n, 3), dtype=np.float32)
v = (rng.random((n, 3), dtype=np.float32) - 0.5) * 4.0
ids = np.arange(n, dtype=np.int32)

# Binary little-endian PLY.
ply = np.empty(n, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("vx", "<f4"),
                         ("vy", "<f4"), ("vz", "<f4"), ("id", "<i4")])
for k, name in enumerate("xyz"):
    ply[name] = p[:, k]
    ply["v" + name] = v[:, k]
ply["id"] = ids
with open(os.path.join(out, "frame.ply"), "wb") as f:
    f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
             + "".join("property float %s\n" % c for c in ["x", "y", "z", "vx", "vy", "vz"])
             + "property int id\nend_header\n").encode())
    f.write(ply.tobytes())

# VTK's writers: an unstructured grid of points with point data, as SPH codes save.
grid = vtk.vtkUnstructuredGrid()
points = vtk.vtkPoints()
points.SetData(numpy_support.numpy_to_vtk(p, deep=True))
grid.SetPoints(points)
for name, array in [("velocity", v), ("id", ids)]:
    a = numpy_support.numpy_to_vtk(array, deep=True)
    a.SetName(name)
    grid.GetPointData().AddArray(a)

legacy = vtk.vtkUnstructuredGridWriter()
legacy.SetFileName(os.path.join(out, "frame.vtk"))
legacy.SetInputData(grid)
legacy.SetFileTypeToBinary()
assert legacy.Write() == 1


def vtu(name, mode, compressor):
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetFileName(os.path.join(out, name))
    w.SetInputData(grid)
    {"appended": w.SetDataModeToAppended, "binary": w.SetDataModeToBinary}[mode]()
    w.SetEncodeAppendedData(False)
    {"none": w.SetCompressorTypeToNone, "zlib": w.SetCompressorTypeToZLib}[compressor]()
    assert w.Write() == 1, name


vtu("frame_raw.vtu", "appended", "none")
vtu("frame_zlib.vtu", "appended", "zlib")
vtu("frame_base64_zlib.vtu", "binary", "zlib")

# Classic BGEO version 5 as partio writes it: big endian, P as x y z w, then `v` (vector)
# and `id` (int) per point, gzipped.
header = np.array([5, n, 0, 0, 0, 2, 0, 0, 0], dtype=">i4").tobytes()
attrs = b""
for name, size, kind in [("v", 3, 5), ("id", 1, 1)]:
    attrs += np.array([len(name)], dtype=">u2").tobytes() + name.encode()
    attrs += np.array([size], dtype=">u2").tobytes() + np.array([kind], dtype=">i4").tobytes()
    attrs += bytes(4 * size)
rec = np.empty(n, dtype=[("p", ">f4", 4), ("v", ">f4", 3), ("id", ">i4")])
rec["p"][:, :3] = p
rec["p"][:, 3] = 1.0
rec["v"] = v
rec["id"] = ids
with gzip.open(os.path.join(out, "frame.bgeo"), "wb", compresslevel=6) as f:
    f.write(b"BgeoV" + header + attrs + rec.tobytes() + b"\x00\xff")

# splashsurf's JSON and a CSV with a header.
with open(os.path.join(out, "frame.json"), "w") as f:
    json.dump(p.tolist(), f)
table = np.concatenate([p, v, ids[:, None].astype(np.float32)], axis=1)
np.savetxt(os.path.join(out, "frame.csv"), table, delimiter=",", fmt="%.9g",
           header="x,y,z,vx,vy,vz,id", comments="")
with open(os.path.join(out, "done"), "w") as f:
    f.write(str(n))
