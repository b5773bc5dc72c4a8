"""Writes a small synthetic Cascade output folder for the Blender check.

A sphere of radius 0.1 m moves at a known velocity (translation plus a spin
about the scene's z axis) and is meshed at a different resolution on every
frame, so the vertex count changes from frame to frame, as Cascade's surface
meshes do. Files, in the formats `cascade surface` writes:

    OUT/mesh/fluid.NNNN.ply      binary little-endian PLY with nx ny nz vx vy vz
    OUT/mesh/fluid.NNNN.obj      (--format obj) ASCII OBJ, no velocities
    OUT/surface/surface.NNNN.vdb (--vdb, needs pyopenvdb: Debian python3-openvdb)
                                 level set "surface" and Vec3s grid "v"
    OUT/scene.json               {"output": {"fps": FPS}}

Run with Blender's Python (numpy is needed; Debian: python3-numpy):
    blender -b --factory-startup --python tests/blender/make_test_ply.py -- OUT
or with a python3 that has numpy:
    python3 tests/blender/make_test_ply.py OUT [--frames 3] [--fps 24] [--up y|z]
                     [--format ply|obj] [--vdb] [--resolution 10] [--speed 1] [--no-velocity]
"""
import argparse
import json
import os
import sys

import numpy as np

RADIUS = 0.1
CENTER0 = np.array([0.5, 0.2, 0.3])       # scene (z-up) metres at t = 0
VELOCITY = np.array([3.0, 0.0, 1.0])      # m/s, scene axes
OMEGA = np.array([0.0, 0.0, 4.0])         # rad/s, spin about the scene's z axis


def sphere(center, n_lat, n_lon):
    """Triangulated UV sphere: positions, unit normals, triangles (int)."""
    theta = np.linspace(0.0, np.pi, n_lat + 1)[1:-1]              # rings, poles excluded
    phi = np.linspace(0.0, 2.0 * np.pi, n_lon, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    unit = np.vstack([[0.0, 0.0, 1.0], ring, [0.0, 0.0, -1.0]])
    top, bottom = 0, len(unit) - 1
    c = np.arange(n_lon)
    cn = (c + 1) % n_lon
    caps = np.concatenate([
        np.stack([np.full(n_lon, top), 1 + c, 1 + cn], -1),
        np.stack([np.full(n_lon, bottom), 1 + (n_lat - 2) * n_lon + cn, 1 + (n_lat - 2) * n_lon + c], -1)])
    r = np.arange(n_lat - 2)[:, None]
    a, b = 1 + r * n_lon + c, 1 + r * n_lon + cn                       # two triangles a quad
    d, e = a + n_lon, b + n_lon
    bands = np.stack([np.stack([a, d, e], -1), np.stack([a, e, b], -1)], 2).reshape(-1, 3)
    tris = np.concatenate([caps, bands]).astype(np.int64)
    return center + RADIUS * unit, unit, np.array(tris, dtype=np.int64)


def to_file_axes(a, up):
    """Scene (z-up) vectors to the file's axes: y-up stores (x, z, -y)."""
    if up == "z":
        return a
    return np.stack([a[:, 0], a[:, 2], -a[:, 1]], -1)


def write_ply(path, pos, nrm, vel, tris, up):
    """As Cascade's writePly: x y z, nx ny nz, vx vy vz (vel None: left out)."""
    comment = ("up: y (a scene point x, y, z is stored as x, z, -y)" if up == "y"
               else "up: z (scene coordinates)")
    props = ["x", "y", "z", "nx", "ny", "nz"] + (["vx", "vy", "vz"] if vel is not None else [])
    header = ("ply\nformat binary_little_endian 1.0\ncomment Cascade surface mesh\n"
              f"comment {comment}\nelement vertex {len(pos)}\n"
              + "".join(f"property float {p}\n" for p in props)
              + f"element face {len(tris)}\nproperty list uchar uint vertex_indices\nend_header\n")
    vrec = np.hstack([pos, nrm] + ([vel] if vel is not None else [])).astype("<f4")
    frec = np.zeros(len(tris), dtype=np.dtype([("n", "u1"), ("i", "<u4", (3,))]))
    frec["n"] = 3
    frec["i"] = tris
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(vrec.tobytes())
        f.write(frec.tobytes())
    os.replace(tmp, path)


def write_obj(path, pos, nrm, tris, up):
    comment = ("up: y (a scene point x, y, z is stored as x, z, -y)" if up == "y"
               else "up: z (scene coordinates)")
    with open(path, "w") as f:
        f.write(f"# Cascade triangle mesh: {len(pos)} vertices, {len(tris)} triangles\n# {comment}\n")
        f.writelines("v %.9g %.9g %.9g\n" % tuple(p) for p in pos)
        f.writelines("vn %.9g %.9g %.9g\n" % tuple(n) for n in nrm)
        f.writelines("f %d//%d %d//%d %d//%d\n" % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1)
                     for a, b, c in tris)


def write_vdb(path, center, speed=1.0):
    import pyopenvdb as vdb
    voxel = 0.01
    ls = vdb.createLevelSetSphere(radius=RADIUS, center=tuple(center), voxelSize=voxel, halfWidth=3.0)
    ls.name = "surface"
    v = vdb.Vec3SGrid(background=(0.0, 0.0, 0.0))
    v.name = "v"
    v.transform = ls.transform
    lo = np.floor((center - RADIUS) / voxel).astype(int) - 3
    hi = np.ceil((center + RADIUS) / voxel).astype(int) + 3
    v.fill(tuple(int(x) for x in lo), tuple(int(x) for x in hi), tuple(float(x) for x in speed * VELOCITY))
    vdb.write(path, grids=[ls, v], metadata={"cascade_up_axis": "z"})


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--fps", type=float, default=24.0)
    ap.add_argument("--up", choices=["y", "z"], default="y")
    ap.add_argument("--format", choices=["ply", "obj"], default="ply")
    ap.add_argument("--vdb", action="store_true", help="also write surface VDBs (pyopenvdb)")
    ap.add_argument("--resolution", type=int, default=10,
                    help="latitude rings of frame 0 (frame n: + 2n; longitudes twice that)")
    ap.add_argument("--speed", type=float, default=1.0, help="scales the velocity and the spin")
    ap.add_argument("--no-velocity", action="store_true", help="PLY without vx vy vz")
    a = ap.parse_args(argv)
    os.makedirs(os.path.join(a.out, "mesh"), exist_ok=True)
    with open(os.path.join(a.out, "scene.json"), "w") as f:
        json.dump({"output": {"fps": a.fps}}, f)
    for n in range(1, a.frames + 1):
        t = n / a.fps
        center = CENTER0 + a.speed * VELOCITY * t
        pos, nrm, tris = sphere(center, a.resolution + 2 * n, 2 * a.resolution - 4 + 4 * n)
        vel = a.speed * (VELOCITY + np.cross(OMEGA, pos - center))
        stem = os.path.join(a.out, "mesh", "fluid.%04d" % n)
        if a.format == "ply":
            write_ply(stem + ".ply", to_file_axes(pos, a.up), to_file_axes(nrm, a.up),
                      None if a.no_velocity else to_file_axes(vel, a.up), tris, a.up)
        else:
            write_obj(stem + ".obj", to_file_axes(pos, a.up), to_file_axes(nrm, a.up), tris, a.up)
        if a.vdb:
            os.makedirs(os.path.join(a.out, "surface"), exist_ok=True)
            write_vdb(os.path.join(a.out, "surface", "surface.%04d.vdb" % n), center, a.speed)
        print("make_test_ply: frame %d: %d vertices, %d triangles, max |v| %.3f m/s"
              % (n, len(pos), len(tris), np.linalg.norm(vel, axis=1).max()))


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    main(argv)
