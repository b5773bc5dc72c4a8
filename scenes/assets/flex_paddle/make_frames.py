#!/usr/bin/env python3
"""Writes the frames of scenes/flex_paddle.json's deforming paddle: paddle.0000.obj
(t = 0) to paddle.0060.obj (t = 2 s at 30 fps), next to this script.

The paddle is a plate 0.02 m thick, 0.18 m wide (y) and 0.25 m tall (z), clamped at
the floor, that bends back and forth like a fin: its mid-surface is
x(z, t) = A (z / L)^2 sin(2 pi t / T) r(t), with A = 0.05 m at the top, T = 0.8 s and
r(t) = (1 - cos(pi t / T)) / 2 over the first period (then 1), so it starts at rest.
Each of its 13 cross-sections stays normal to the bent mid-surface (the plate keeps
its thickness). The same 52 vertices and 100 triangles in every frame, outward
oriented; coordinates are the paddle's own (the scene places it with "translate").
"""
import math
import os

THICKNESS, WIDTH, LENGTH = 0.02, 0.18, 0.25
AMPLITUDE, PERIOD, FPS, LAST = 0.05, 0.8, 30, 60
LEVELS = 13


def frame(t):
    ramp = 1.0 if t >= PERIOD else 0.5 * (1 - math.cos(math.pi * t / PERIOD))
    s = AMPLITUDE * math.sin(2 * math.pi * t / PERIOD) * ramp
    vertices = []
    for i in range(LEVELS):
        z = LENGTH * i / (LEVELS - 1)
        x = s * (z / LENGTH) ** 2
        slope = 2 * s * z / LENGTH ** 2          # dx/dz of the mid-surface
        n = math.hypot(1.0, slope)
        nx, nz = 1.0 / n, -slope / n             # the section's direction (normal to it)
        for side in (-1, 1):                     # back (-x), front (+x)
            for y in (-WIDTH / 2, WIDTH / 2):
                vertices.append((x + side * THICKNESS / 2 * nx, y, z + side * THICKNESS / 2 * nz))
    return vertices


def index(level, side, y):  # 0-based
    return 4 * level + 2 * side + y


def triangles():
    quads = []
    for i in range(LEVELS - 1):
        a, b = i, i + 1
        quads.append((index(a, 1, 0), index(a, 1, 1), index(b, 1, 1), index(b, 1, 0)))  # front (+x)
        quads.append((index(a, 0, 1), index(a, 0, 0), index(b, 0, 0), index(b, 0, 1)))  # back (-x)
        quads.append((index(a, 0, 0), index(a, 1, 0), index(b, 1, 0), index(b, 0, 0)))  # -y side
        quads.append((index(a, 1, 1), index(a, 0, 1), index(b, 0, 1), index(b, 1, 1)))  # +y side
    top = LEVELS - 1
    quads.append((index(0, 0, 0), index(0, 0, 1), index(0, 1, 1), index(0, 1, 0)))      # bottom (-z)
    quads.append((index(top, 1, 0), index(top, 1, 1), index(top, 0, 1), index(top, 0, 0)))  # top (+z)
    result = []
    for a, b, c, d in quads:
        result += [(a, b, c), (a, c, d)]
    return result


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    faces = triangles()
    for k in range(LAST + 1):
        lines = ["# scenes/flex_paddle.json paddle, frame %d (t = %.6g s); made by make_frames.py" % (k, k / FPS)]
        lines += ["v %.6f %.6f %.6f" % v for v in frame(k / FPS)]
        lines += ["f %d %d %d" % (a + 1, b + 1, c + 1) for a, b, c in faces]
        with open(os.path.join(here, "paddle.%04d.obj" % k), "w") as out:
            out.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
