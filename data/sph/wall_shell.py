"""How much of a dam break's meshes stands as a shell off its tank's walls: per frame, the
area of the faces 0.1 r to 2 r off a wall (inside the tank) and facing it, and the area
lying on a wall (within 0.1 r). Without a collider a skin closes a radius or two off the
walls; met with the tank (`--collider`), the liquid lies on them.

    python3 data/sph/wall_shell.py 'out/dam_####.obj' 1-36
"""
import sys

import numpy as np

R = 0.005
X, Y, Z = 0.9, 0.6, 0.35
# (axis, plane, the wall's side seen from the liquid); the top is open.
WALLS = [(0, 0.0, -1), (0, X, 1), (2, 0.0, -1), (2, Z, 1), (1, 0.0, -1)]


def load(path):
    v, f = [], []
    with open(path) as obj:
        for line in obj:
            if line.startswith("v "):
                v.append([float(a) for a in line.split()[1:4]])
            elif line.startswith("f "):
                f.append([int(a.split("/")[0]) - 1 for a in line.split()[1:4]])
    return np.array(v), np.array(f)


def shell_and_wet(path):
    v, f = load(path)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    cross = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    normal = cross / np.maximum(2 * area, 1e-30)[:, None]
    centre = (a + b + c) / 3
    shell = wet = 0.0
    for axis, plane, side in WALLS:
        off = (plane - centre[:, axis]) * side
        facing = normal[:, axis] * side > 0.9
        shell += area[facing & (off > 0.1 * R) & (off < 2 * R)].sum()
        wet += area[facing & (np.abs(off) <= 0.1 * R)].sum()
    return shell, wet


def main(pattern, frames):
    first, last = (int(x) for x in frames.split("-"))
    width = pattern.count("#")
    rows = [
        shell_and_wet(pattern.replace("#" * width, str(n).zfill(width)))
        for n in range(first, last + 1)
    ]
    shell, wet = (np.array(x) * 1e4 for x in zip(*rows))
    print(
        f"shell off the walls, cm² a frame: mean {shell.mean():.2f}, max {shell.max():.2f}; "
        f"on the walls: mean {wet.mean():.0f}"
    )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
