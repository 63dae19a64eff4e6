"""The dam break's tank (bake_dam_break.py: inside [0, 0.9] x [0, 0.6] x [0, 0.35], open at
the top) as a closed OBJ for `--collider`: its floor and four walls, boxes 5 cm thick.

    python3 data/sph/dam_break_tank.py tank.obj
"""
import sys

T = 0.05
X, Y, Z = 0.9, 0.6, 0.35
BOXES = [
    ((-T, -T, -T), (X + T, 0, Z + T)),  # floor
    ((-T, -T, -T), (0, Y, Z + T)),
    ((X, -T, -T), (X + T, Y, Z + T)),
    ((-T, -T, -T), (X + T, Y, 0)),
    ((-T, -T, Z), (X + T, Y, Z + T)),
]
# Each box's faces, outward, as quads of its corners (corner c has bit a set: hi on axis a).
QUADS = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]


def main(path):
    with open(path, "w") as out:
        for lo, hi in BOXES:
            for c in range(8):
                out.write("v %g %g %g\n" % tuple(hi[a] if c >> a & 1 else lo[a] for a in range(3)))
        for b in range(len(BOXES)):
            for q in QUADS:
                a, b_, c, d = (8 * b + i + 1 for i in q)
                out.write("f %d %d %d\nf %d %d %d\n" % (a, b_, c, a, c, d))


if __name__ == "__main__":
    main(sys.argv[1])
