"""Checks tools/blender/cascade_import.py on a Cascade output folder, in Blender.

    blender -b --factory-startup -P tools/blender/check_import.py -- OUT [--keep DIR]
                                                                       [--allow-no-velocity]

Imports OUT with cascade_import.py, then for at least two frames compares what
Blender holds with the files, read here independently with numpy: vertex and
triangle counts, the bounding box (<= 1e-5 m after the y-up -> z-up turn) and
the "velocity" attribute (max abs difference <= 1e-5 m/s). If OUT has surface
VDBs, checks that the volume object shows VDB frame N at Blender frame N.
Renders a 64x36 Cycles image (CPU, 1 sample, fixed orthographic camera on the
mesh's bounding box) with motion blur off, on, and on with the velocity
attribute zeroed (control), and requires blur-on to differ both from blur-off
and from the control: the difference comes from the velocity values.
Prints PASS lines with the figures; on a failure prints one FAIL line and
exits 1. --keep DIR keeps the three PNGs; --allow-no-velocity passes an
OBJ-only OUT (no velocities) without the render.
"""
import importlib.util
import json
import os
import sys
import tempfile
import time
import traceback

import bpy
import numpy as np

TOL_POS = 1e-5      # m
TOL_VEL = 1e-5      # m/s
WIDTH, HEIGHT = 64, 36


class CheckFailed(Exception):
    pass


def fail(msg):
    raise CheckFailed(msg)


def load_importer():
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cascade_import.py")
    spec = importlib.util.spec_from_file_location("cascade_import", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# ---- independent readers of Cascade's files -------------------------------------------

XYZ, NRM, VEL = ["x", "y", "z"], ["nx", "ny", "nz"], ["vx", "vy", "vz"]
# Cascade writes x y z, then nx ny nz and vx vy vz unless left out (--no-velocity)
CASCADE_VERTEX_PROPS = [XYZ + NRM + VEL, XYZ + NRM, XYZ + VEL, XYZ]


def read_cascade_ply(path):
    """Cascade's binary PLY, header as documented; returns (up, xyz, vel or
    None, tris) in the file's axes."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    lines = data[:end].decode("ascii").splitlines()
    if lines[:3] != ["ply", "format binary_little_endian 1.0", "comment Cascade surface mesh"]:
        fail(f"{path}: header starts {lines[:3]}")
    up = None
    props, nv, nf, face_prop = [], None, None, None
    for ln in lines:
        w = ln.split()
        if ln.startswith("comment up:"):
            up = w[2]
        elif w[:2] == ["element", "vertex"]:
            nv = int(w[2])
        elif w[:2] == ["element", "face"]:
            nf = int(w[2])
        elif w[0] == "property" and w[1] == "float" and nf is None:
            props.append(w[2])
        elif w[0] == "property" and w[1] == "list":
            face_prop = w[1:]
    if props not in CASCADE_VERTEX_PROPS or face_prop != ["list", "uchar", "uint", "vertex_indices"]:
        fail(f"{path}: unexpected properties {props} / {face_prop}")
    if up not in ("y", "z"):
        fail(f"{path}: no 'comment up: y|z' line")
    k = len(props)
    vert = np.frombuffer(data, dtype="<f4", count=k * nv, offset=end).reshape(nv, k).astype(np.float64)
    off = end + 4 * k * nv
    faces = np.frombuffer(data, dtype=np.dtype([("n", "u1"), ("i", "<u4", (3,))]), count=nf, offset=off)
    if len(data) != off + 13 * nf:
        fail(f"{path}: {len(data) - off - 13 * nf} bytes after the last face")
    if nf and not np.all(faces["n"] == 3):
        fail(f"{path}: a face that is not a triangle")
    vel = vert[:, props.index("vx"):props.index("vx") + 3] if "vx" in props else None
    return up, vert[:, 0:3], vel, faces["i"].astype(np.int64)


def read_cascade_obj(path):
    up, v, f = "z", [], []
    for ln in open(path):
        if ln.startswith("# up:"):
            up = ln.split()[2]
        elif ln.startswith("v "):
            v.append([float(x) for x in ln.split()[1:4]])
        elif ln.startswith("f "):
            f.append([int(t.split("/")[0]) - 1 for t in ln.split()[1:]])
    return up, np.array(v, np.float64).reshape(-1, 3), None, np.array(f, np.int64)


def y_up_to_blender(a, up):
    """File (x, y, z) -> Blender (x, -z, y) for y-up files."""
    if a is None or up != "y":
        return a
    return np.stack([a[:, 0], -a[:, 2], a[:, 1]], axis=-1)


# ---- rendering -----------------------------------------------------------------------

def setup_render(scene, obj, bbox_min, bbox_max):
    for o in list(scene.objects):
        if o is not obj and o.type != "VOLUME":
            bpy.data.objects.remove(o, do_unlink=True)
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = 1
    cy.use_denoising = False
    cy.use_adaptive_sampling = False
    cy.seed = 0
    scene.render.threads_mode = "FIXED"
    scene.render.threads = 2
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.image_settings.color_depth = "16"
    scene.render.motion_blur_shutter = 0.5
    cy.motion_blur_position = "CENTER"
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs[0].default_value = (0.05, 0.05, 0.05, 1.0)
    centre = (bbox_min + bbox_max) / 2
    ext = bbox_max - bbox_min
    cam_data = bpy.data.cameras.new("CheckCamera")
    cam_data.type = "ORTHO"
    # looking along +y (Blender's front view): image x = world x, image up = world z
    cam_data.ortho_scale = float(1.25 * max(ext[0], ext[2] * WIDTH / HEIGHT, 1e-3))
    cam_data.clip_start = 1e-3
    cam_data.clip_end = float(10 * (ext.max() + 1.0))
    cam = bpy.data.objects.new("CheckCamera", cam_data)
    cam.location = (float(centre[0]), float(bbox_min[1] - 2 * ext.max() - 0.1), float(centre[2]))
    cam.rotation_euler = (np.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun_data = bpy.data.lights.new("CheckSun", "SUN")
    sun_data.energy = 4.0
    sun = bpy.data.objects.new("CheckSun", sun_data)
    sun.rotation_euler = (np.radians(60), 0.0, np.radians(-30))
    scene.collection.objects.link(sun)


def render_png(scene, path, motion_blur):
    scene.render.use_motion_blur = motion_blur
    scene.render.filepath = path
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    dt = time.perf_counter() - t0
    img = bpy.data.images.load(path, check_existing=False)
    px = np.empty(WIDTH * HEIGHT * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(HEIGHT, WIDTH, 4), dt


def coverage_columns(img):
    """Image columns where the object covers any pixel (alpha > 0)."""
    cols = np.nonzero(img[:, :, 3].max(axis=0) > 0)[0]
    return (int(cols.min()), int(cols.max())) if len(cols) else (-1, -1)


# ---- the check -----------------------------------------------------------------------

def pick_frames(frames):
    if len(frames) < 2:
        fail(f"need at least two mesh frames, found {len(frames)}")
    if len(frames) <= 4:
        return list(frames)
    idx = sorted({0, len(frames) // 3, 2 * len(frames) // 3, len(frames) - 1})
    return [frames[i] for i in idx]


def run(out, keep_dir, allow_no_velocity=False):
    t_all = time.perf_counter()
    ci = load_importer()
    scene = bpy.context.scene
    t0 = time.perf_counter()
    res = ci.import_cascade(out)
    t_import = time.perf_counter() - t0
    obj = res["mesh"]
    if obj is None:
        fail(f"{out}: no mesh frames imported")
    frames = res["mesh_frames"]
    if (scene.frame_start, scene.frame_end) != (frames[0], frames[-1]):
        fail(f"frame range {scene.frame_start}-{scene.frame_end}, files {frames[0]}-{frames[-1]}")
    try:
        with open(os.path.join(out, "scene.json")) as f:
            want_fps = float(json.load(f).get("output", {}).get("fps", 24))
    except OSError:
        want_fps = 24.0
    got_fps = scene.render.fps / scene.render.fps_base
    if abs(got_fps - want_fps) > 1e-6 * want_fps:
        fail(f"scene fps {got_fps}, scene.json {want_fps}")
    if not any(getattr(h, "__name__", "") == "cascade_frame_change_pre"
               for h in bpy.app.handlers.frame_change_pre):
        fail("no cascade_frame_change_pre handler registered")
    print(f"PASS import: {len(frames)} mesh frames {frames[0]}-{frames[-1]}, "
          f"{len(res['vdb_frames'])} VDB frames, fps {got_fps:g}, {t_import:.2f} s")

    best = None  # (mean speed, frame, bbox)
    counts = []
    for fr in pick_frames(frames):
        t0 = time.perf_counter()
        scene.frame_set(fr)
        t_load = time.perf_counter() - t0
        path = ci.mesh_path(res["out"], fr)
        if path.endswith(".ply"):
            up, xyz, vel, tris = read_cascade_ply(path)
        else:
            up, xyz, vel, tris = read_cascade_obj(path)
        want_p = y_up_to_blender(xyz, up)
        want_v = y_up_to_blender(vel, up)
        me = obj.data
        nv, nt = len(me.vertices), len(me.polygons)
        if nv != len(want_p) or nt != len(tris):
            fail(f"frame {fr}: Blender has {nv} vertices / {nt} faces, {os.path.basename(path)} "
                 f"{len(want_p)} / {len(tris)}")
        counts.append(nv)
        co = np.empty(3 * nv, np.float32)
        me.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3).astype(np.float64)
        loops = np.empty(len(me.loops), np.int32)
        me.loops.foreach_get("vertex_index", loops)
        if not np.array_equal(loops, tris.ravel()):
            fail(f"frame {fr}: triangle vertex indices differ from {os.path.basename(path)}")
        bb_min, bb_max = co.min(0), co.max(0)
        d_bbox = max(np.abs(bb_min - want_p.min(0)).max(), np.abs(bb_max - want_p.max(0)).max())
        d_pos = np.abs(co - want_p).max()
        if d_bbox > TOL_POS:
            fail(f"frame {fr}: bounding box differs by {d_bbox:.3g} m (> {TOL_POS:g})")
        msg = (f"PASS frame {fr}: {nv} vertices, {nt} triangles ({up}-up file), bbox diff {d_bbox:.2g} m, "
               f"max vertex diff {d_pos:.2g} m, bbox min {np.round(bb_min, 4).tolist()} "
               f"max {np.round(bb_max, 4).tolist()}")
        if want_v is not None:
            attr = me.attributes.get("velocity")
            if attr is None or attr.domain != "POINT" or attr.data_type != "FLOAT_VECTOR":
                fail(f"frame {fr}: no POINT FLOAT_VECTOR attribute 'velocity'")
            v = np.empty(3 * nv, np.float32)
            attr.data.foreach_get("vector", v)
            v = v.reshape(-1, 3).astype(np.float64)
            d_vel = np.abs(v - want_v).max() if nv else 0.0
            if d_vel > TOL_VEL:
                fail(f"frame {fr}: velocity differs by {d_vel:.3g} m/s (> {TOL_VEL:g})")
            speed = float(np.linalg.norm(v, axis=1).mean()) if nv else 0.0
            msg += f", velocity max diff {d_vel:.2g} m/s, mean |v| {speed:.3f} m/s"
            if nv and (best is None or speed > best[0]):
                best = (speed, fr, bb_min, bb_max)
        print(msg + f", loaded in {t_load:.3f} s")
    if len(set(counts)) == 1 and len(counts) > 1:
        print(f"NOTE: all checked frames have {counts[0]} vertices")

    vol = res["volume"]
    if res["vdb_frames"]:
        if vol is None:
            fail("surface VDBs present but no volume object")
        if not vol.hide_render:
            fail("volume object is not hidden from render")
        for fr in pick_frames(res["vdb_frames"])[:2]:
            scene.frame_set(fr)
            ev = vol.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
            ev.grids.load()
            want = os.path.join(res["out"], "surface", "surface.%04d.vdb" % fr)
            names = [g.name for g in ev.grids]
            if os.path.normpath(bpy.path.abspath(ev.grids.frame_filepath)) != os.path.normpath(want):
                fail(f"frame {fr}: volume shows {ev.grids.frame_filepath}, want {want}")
            if "surface" not in names:
                fail(f"frame {fr}: volume grids {names} have no 'surface' ({ev.grids.error_message})")
            if "v" in names and vol.data.velocity_grid != "v":
                fail(f"volume velocity grid is '{vol.data.velocity_grid}', want 'v'")
            print(f"PASS volume frame {fr}: {os.path.basename(want)}, grids {names}, "
                  f"velocity grid '{vol.data.velocity_grid}' ({vol.data.velocity_unit}), hidden from render")

    if best is None:
        if allow_no_velocity:
            print(f"check_import: PASS, render skipped: no velocities (OBJ or --no-velocity) "
                  f"({time.perf_counter() - t_all:.1f} s)")
            return
        fail("no frame with velocities to render (OBJ only? --allow-no-velocity skips the render)")
    speed, fr, bb_min, bb_max = best
    scene.frame_set(fr)
    setup_render(scene, obj, bb_min, bb_max)
    tmp = keep_dir or tempfile.mkdtemp(prefix="cascade_check_")
    os.makedirs(tmp, exist_ok=True)
    img_off, t_off = render_png(scene, os.path.join(tmp, "blur_off.png"), False)
    img_on, t_on = render_png(scene, os.path.join(tmp, "blur_on.png"), True)
    # control: motion blur on, the same "velocity" attribute set to zero. (A zero
    # velocity attribute alone already changes a 1-sample image a little, as Cycles
    # then samples shutter time; removing the attribute gives the blur-off image.)
    attr = obj.data.attributes["velocity"]
    saved = np.empty(3 * len(attr.data), np.float32)
    attr.data.foreach_get("vector", saved)
    out_prop = obj["cascade_out"]
    del obj["cascade_out"]          # the handler leaves the object alone meanwhile
    attr.data.foreach_set("vector", np.zeros_like(saved))
    obj.data.update()
    img_ctl, t_ctl = render_png(scene, os.path.join(tmp, "blur_on_zero_velocity.png"), True)
    obj.data.attributes["velocity"].data.foreach_set("vector", saved)
    obj.data.update()
    obj["cascade_out"] = out_prop
    d_blur = float(np.abs(img_on - img_off).sum())
    d_vel = float(np.abs(img_on - img_ctl).sum())
    d_ctl = float(np.abs(img_ctl - img_off).sum())
    c_off, c_on = coverage_columns(img_off), coverage_columns(img_on)
    px_m = WIDTH / scene.camera.data.ortho_scale
    blur_m = speed * scene.render.motion_blur_shutter / got_fps
    print(f"PASS render frame {fr}: sum |blur on - blur off| = {d_blur:.2f} (RGBA, {WIDTH}x{HEIGHT}); "
          f"blur on with velocity vs zero velocity {d_vel:.2f}; zero velocity vs blur off {d_ctl:.2f}; "
          f"covered columns off {c_off}, on {c_on}; expected blur ~ {blur_m * px_m:.1f} px "
          f"(mean |v| {speed:.3f} m/s x shutter 0.5 / {got_fps:g} fps); "
          f"render {t_off:.2f} / {t_on:.2f} / {t_ctl:.2f} s")
    if d_blur <= 1.0:
        fail(f"motion blur on and off images differ by only {d_blur:.3f}")
    if d_vel <= 1.0:
        fail(f"the velocity values change the blurred image by only {d_vel:.3f} (vs zero velocity)")
    if keep_dir:
        print(f"images kept in {keep_dir}")
    print(f"check_import: PASS ({time.perf_counter() - t_all:.1f} s)")


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    keep = None
    if "--keep" in argv:
        i = argv.index("--keep")
        keep = os.path.abspath(argv[i + 1])
        del argv[i:i + 2]
    allow = "--allow-no-velocity" in argv
    if allow:
        argv.remove("--allow-no-velocity")
    if len(argv) != 1:
        print("FAIL: usage: blender -b --factory-startup -P check_import.py -- OUT [--keep DIR] "
              "[--allow-no-velocity]")
        sys.exit(1)
    try:
        run(os.path.abspath(argv[0]), keep, allow)
    except CheckFailed as e:
        print(f"FAIL: {e}")
        sys.stdout.flush()
        sys.exit(1)
    except Exception as e:  # a crash in the importer or here is a failure too
        traceback.print_exc()
        print(f"FAIL: {type(e).__name__}: {e}")
        sys.stdout.flush()
        sys.exit(1)


main()
