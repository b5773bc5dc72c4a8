"""Load a Cascade output folder (OUT) into Blender (checked with Blender 3.4.1).

Command line:
    blender [shot.blend] -P tools/blender/cascade_import.py -- OUT
            [--no-volume] [--fps-from-scene | --keep-fps] [--file-normals] [--motion-blur]

From Blender's Text Editor: open this file, set CASCADE_OUT below, Run Script.

What it makes:
  * object "CascadeFluid": a mesh whose data is replaced on every frame change
    (a persistent frame_change_pre handler) by OUT/mesh/fluid.NNNN.ply, or
    fluid.NNNN.obj where there is no PLY, NNNN = Blender's frame. y-up files
    ("up: y" comment) are turned back to Blender's z-up: file (x, y, z) ->
    Blender (x, -z, y), for positions, normals and velocities. Faces are
    smooth shaded with Blender's normals; --file-normals uses the files'
    normals instead (custom split normals, about 5 s more per 1M-vertex frame).
    Frames outside the files' range show an empty mesh.
  * on it a FLOAT_VECTOR POINT attribute "velocity" (m/s, from PLY vx vy vz):
    Cycles (Blender >= 3.1) motion-blurs the mesh with it, moving each vertex by
    velocity * (+-shutter / 2) / fps seconds. OBJ files carry no velocity.
  * object "CascadeSurface" (unless --no-volume): a volume sequence of
    OUT/surface/surface.NNNN.vdb, VDB frame N at Blender frame N, velocity grid
    "v" (m/s) for volume motion blur, hidden from render (the mesh is the
    surface to render; show it with the object's camera icon if wanted).
  * the scene's frame range from the files found and its fps from
    OUT/scene.json output.fps (default 24); --keep-fps keeps Blender's fps, but
    then velocity blur no longer matches the frame-to-frame motion.
  * a text block "cascade_import.py" registered as a module, so a saved .blend
    re-installs the handler when opened with Python auto-run allowed
    (Preferences > Save & Load > Auto Run Python Scripts, or `blender -y`).
"""
import json
import os
import re
import sys
import time

import bpy
import numpy as np
from bpy.app.handlers import persistent

# ---- Settings used when run from Blender's Text Editor (no "--" arguments) ----
CASCADE_OUT = ""        # the Cascade output folder, e.g. "/shots/dam/out"
LOAD_VOLUME = True      # also load OUT/surface/surface.####.vdb
FPS_FROM_SCENE = True   # scene fps from OUT/scene.json output.fps
FILE_NORMALS = False    # use the files' normals (custom split normals; ~5 s more a 1M-vertex frame)
MOTION_BLUR = False     # also switch on Render Properties > Motion Blur
# -------------------------------------------------------------------------------

MESH_OBJECT = "CascadeFluid"
VOLUME_OBJECT = "CascadeSurface"
TEXT_NAME = "cascade_import.py"
HANDLER_NAME = "cascade_frame_change_pre"

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
_FRAME_RE = re.compile(r"^fluid\.(\d+)\.(ply|obj)$")
_VDB_RE = re.compile(r"^surface\.(\d+)\.vdb$")
_UP_RE = re.compile(r"up:\s*([xyz])", re.IGNORECASE)

# mesh datablock pointer -> (path, mtime, size) of the file it holds now (None: emptied)
_loaded = {}
_NEVER = object()


class MeshFrame:
    """One frame's mesh in Blender's axes: float32 positions (N, 3), normals
    (N, 3) or None, velocities (N, 3) or None; int32 loop vertex indices,
    polygon loop starts and loop totals."""

    def __init__(self, positions, normals, velocity, loops, loop_start, loop_total, up):
        self.positions, self.normals, self.velocity = positions, normals, velocity
        self.loops, self.loop_start, self.loop_total, self.up = loops, loop_start, loop_total, up


def _to_blender_axes(a, up):
    """File axes to Blender's z-up: a y-up file (x, y, z) is Blender (x, -z, y)."""
    if a is None:
        return None
    a = np.asarray(a, dtype=np.float32)
    if up != "y":
        return np.ascontiguousarray(a)
    out = np.empty_like(a)
    out[:, 0] = a[:, 0]
    out[:, 1] = -a[:, 2]
    out[:, 2] = a[:, 1]
    return out


def _columns(rec, names):
    if not all(n in rec.dtype.names for n in names):
        return None
    return np.stack([rec[n].astype(np.float32) for n in names], axis=-1)


def read_ply(path):
    """Binary PLY (little or big endian) with vertex x y z [nx ny nz] [vx vy vz]
    and a face list; returns a MeshFrame in Blender's axes."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.find(b"end_header")
    if end < 0:
        raise ValueError(f"{path}: not a PLY file (no end_header)")
    body = data.index(b"\n", end) + 1
    lines = data[:end].decode("ascii", "replace").splitlines()
    if not lines or lines[0].strip() != "ply":
        raise ValueError(f"{path}: not a PLY file")
    fmt, up, elements = None, "z", []
    for line in lines[1:]:
        w = line.split()
        if not w:
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "comment":
            m = _UP_RE.search(line)
            if m:
                up = m.group(1).lower()
        elif w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property":
            elements[-1][2].append(w[1:])
    if fmt not in ("binary_little_endian", "binary_big_endian"):
        raise ValueError(f"{path}: PLY format {fmt} not supported (binary only)")
    bo = "<" if fmt == "binary_little_endian" else ">"
    offset, vert, faces = body, None, None
    for name, count, props in elements:
        if all(p[0] != "list" for p in props):
            dt = np.dtype([(p[1], bo + _PLY_TYPES[p[0]]) for p in props])
            rec = np.frombuffer(data, dtype=dt, count=count, offset=offset)
            offset += dt.itemsize * count
            if name == "vertex":
                vert = rec
        elif name == "face" and len(props) == 1:
            _, ctype, itype, _pname = props[0]
            ct, it = np.dtype(bo + _PLY_TYPES[ctype]), np.dtype(bo + _PLY_TYPES[itype])
            tri = np.dtype([("n", ct), ("i", it, (3,))])
            if count == 0:
                faces = (np.zeros(0, np.int32), np.zeros(0, np.int32), np.zeros(0, np.int32))
            elif len(data) - offset >= tri.itemsize * count and np.all(
                    np.frombuffer(data, dtype=tri, count=count, offset=offset)["n"] == 3):
                rec = np.frombuffer(data, dtype=tri, count=count, offset=offset)
                offset += tri.itemsize * count
                loops = rec["i"].astype(np.int32).ravel()
                faces = (loops, np.arange(0, 3 * count, 3, dtype=np.int32),
                         np.full(count, 3, dtype=np.int32))
            else:  # polygons of several sizes: walk the records
                loops, totals = [], np.empty(count, np.int32)
                for k in range(count):
                    n = int(np.frombuffer(data, ct, 1, offset)[0])
                    offset += ct.itemsize
                    loops.append(np.frombuffer(data, it, n, offset))
                    offset += it.itemsize * n
                    totals[k] = n
                loop_arr = np.concatenate(loops).astype(np.int32) if loops else np.zeros(0, np.int32)
                starts = np.zeros(count, np.int32)
                starts[1:] = np.cumsum(totals)[:-1]
                faces = (loop_arr, starts, totals)
        else:
            break  # other list elements: nothing after them is needed
    if vert is None or faces is None:
        raise ValueError(f"{path}: PLY needs a vertex element and a face list")
    pos = _columns(vert, ("x", "y", "z"))
    if pos is None:
        raise ValueError(f"{path}: PLY vertex has no x y z")
    nrm = _columns(vert, ("nx", "ny", "nz"))
    vel = _columns(vert, ("vx", "vy", "vz"))
    return MeshFrame(_to_blender_axes(pos, up), _to_blender_axes(nrm, up), _to_blender_axes(vel, up),
                     faces[0], faces[1], faces[2], up)


def read_obj(path):
    """ASCII OBJ (v, vn, f; any polygon size); returns a MeshFrame in Blender's axes."""
    with open(path, "r") as f:
        text = f.read()
    up = "z"
    v, vn, fl = [], [], []
    for line in text.splitlines():
        if line.startswith("v "):
            v.append(line[2:])
        elif line.startswith("vn "):
            vn.append(line[3:])
        elif line.startswith("f "):
            fl.append(line[2:].split())
        elif line.startswith("#"):
            m = _UP_RE.search(line)
            if m:
                up = m.group(1).lower()
    pos = np.array(" ".join(v).split(), dtype=np.float32).reshape(-1, 3)
    nrm = np.array(" ".join(vn).split(), dtype=np.float32).reshape(-1, 3) if vn else None
    if nrm is not None and len(nrm) != len(pos):
        nrm = None  # only vertex-aligned normals (Cascade's i//i) are used
    totals = np.fromiter((len(t) for t in fl), dtype=np.int32, count=len(fl))
    loops = np.array([int(tok.split("/", 1)[0]) for t in fl for tok in t], dtype=np.int64)
    loops = np.where(loops < 0, loops + len(pos), loops - 1).astype(np.int32)
    starts = np.zeros(len(fl), np.int32)
    if len(fl):
        starts[1:] = np.cumsum(totals)[:-1]
    return MeshFrame(_to_blender_axes(pos, up), _to_blender_axes(nrm, up), None, loops, starts, totals, up)


def read_mesh_file(path):
    return read_ply(path) if path.lower().endswith(".ply") else read_obj(path)


def find_frames(out):
    """{frame: path} of OUT/mesh/fluid.NNNN.ply (or .obj where no .ply) and of
    OUT/surface/surface.NNNN.vdb."""
    meshes, vdbs = {}, {}
    mdir, sdir = os.path.join(out, "mesh"), os.path.join(out, "surface")
    if os.path.isdir(mdir):
        for name in sorted(os.listdir(mdir)):
            m = _FRAME_RE.match(name)
            if m:
                n = int(m.group(1))
                if m.group(2) == "ply" or n not in meshes:
                    meshes[n] = os.path.join(mdir, name)
    if os.path.isdir(sdir):
        for name in sorted(os.listdir(sdir)):
            m = _VDB_RE.match(name)
            if m:
                vdbs[int(m.group(1))] = os.path.join(sdir, name)
    return meshes, vdbs


def mesh_path(out, frame):
    for ext in ("ply", "obj"):
        p = os.path.join(out, "mesh", "fluid.%04d.%s" % (frame, ext))
        if os.path.isfile(p):
            return p
    return None


def set_mesh_data(me, fr, file_normals=False):
    """Replaces mesh `me`'s geometry by MeshFrame `fr` (None: empty mesh)."""
    me.clear_geometry()
    if fr is None or len(fr.positions) == 0:
        me.update()
        return
    nv, nl, npoly = len(fr.positions), len(fr.loops), len(fr.loop_start)
    me.vertices.add(nv)
    me.vertices.foreach_set("co", np.ascontiguousarray(fr.positions, np.float32).ravel())
    me.loops.add(nl)
    me.loops.foreach_set("vertex_index", np.ascontiguousarray(fr.loops, np.int32))
    me.polygons.add(npoly)
    me.polygons.foreach_set("loop_start", np.ascontiguousarray(fr.loop_start, np.int32))
    me.polygons.foreach_set("loop_total", np.ascontiguousarray(fr.loop_total, np.int32))
    me.polygons.foreach_set("use_smooth", np.ones(npoly, dtype=bool))
    me.update(calc_edges=True)
    if file_normals and fr.normals is not None:
        me.use_auto_smooth = True
        me.normals_split_custom_set_from_vertices(np.ascontiguousarray(fr.normals, np.float32))
    else:
        me.use_auto_smooth = False
    if fr.velocity is not None:
        attr = me.attributes.get("velocity")
        if attr is not None:
            me.attributes.remove(attr)
        attr = me.attributes.new("velocity", "FLOAT_VECTOR", "POINT")
        attr.data.foreach_set("vector", np.ascontiguousarray(fr.velocity, np.float32).ravel())


def update_fluid_object(obj, frame, force=False):
    """Loads the mesh file for `frame` into `obj` unless it holds it already.
    Returns the path loaded (None: no file for that frame, mesh emptied)."""
    out = obj.get("cascade_out")
    me = obj.data
    path = mesh_path(out, frame)
    key = None
    if path is not None:
        st = os.stat(path)
        key = (path, st.st_mtime_ns, st.st_size)
    if not force and _loaded.get(me.as_pointer(), _NEVER) == key:
        return path
    fr = read_mesh_file(path) if path is not None else None
    set_mesh_data(me, fr, bool(obj.get("cascade_file_normals", 0)))
    _loaded[me.as_pointer()] = key
    return path


@persistent
def cascade_frame_change_pre(scene, depsgraph=None):
    # Cycles calls frame_set at sub-frames to sample motion; the velocity
    # attribute carries the mesh's motion, so keep the whole frame's mesh there.
    if scene.frame_subframe != 0.0:
        return
    for obj in scene.objects:
        if obj.type == "MESH" and obj.get("cascade_out"):
            try:
                update_fluid_object(obj, scene.frame_current)
            except Exception as e:  # a bad file must not stop playback or a render
                print(f"cascade_import: frame {scene.frame_current}: {e}", file=sys.stderr)


def register_handler():
    handlers = bpy.app.handlers.frame_change_pre
    for h in list(handlers):
        if getattr(h, "__name__", "") == HANDLER_NAME:
            handlers.remove(h)
    handlers.append(cascade_frame_change_pre)


def _store_text_module():
    """Keeps this script in the .blend as a module text so the handler is
    registered again when the saved file is opened (Python auto-run allowed)."""
    space = getattr(bpy.context, "space_data", None)
    if getattr(space, "type", "") == "TEXT_EDITOR" and getattr(space, "text", None):
        space.text.use_module = True   # run from the Text Editor: register that text
        return
    txt = bpy.data.texts.get(TEXT_NAME)
    src = None
    path = globals().get("__file__")
    if path and os.path.isfile(path):
        with open(path, "r") as f:
            src = f.read()
    if txt is None:
        if src is None:
            return
        txt = bpy.data.texts.new(TEXT_NAME)
        txt.from_string(src)
    elif src is not None and txt.as_string() != src:
        txt.from_string(src)
    txt.use_module = True


def vdb_up_axis(path):
    """The "cascade_up_axis" string metadata of a VDB file ("z" if absent)."""
    key = b"\x0f\x00\x00\x00cascade_up_axis\x06\x00\x00\x00string"
    with open(path, "rb") as f:
        head = f.read(1 << 18)
    i = head.find(key)
    if i < 0:
        return "z"
    i += len(key)
    n = int.from_bytes(head[i:i + 4], "little")
    return head[i + 4:i + 4 + n].decode("ascii", "replace").strip().lower() or "z"


def read_fps(out):
    try:
        with open(os.path.join(out, "scene.json")) as f:
            fps = float(json.load(f).get("output", {}).get("fps", 24))
    except (OSError, ValueError, AttributeError):
        fps = 24.0
    return fps if fps > 0 else 24.0


def _link(obj, scene):
    if obj.name not in scene.collection.objects and not obj.users_collection:
        scene.collection.objects.link(obj)


def load_volume(out, vdbs, scene):
    first, last = min(vdbs), max(vdbs)
    obj = bpy.data.objects.get(VOLUME_OBJECT)
    if obj is None or obj.type != "VOLUME":
        vol = bpy.data.volumes.new(VOLUME_OBJECT)
        obj = bpy.data.objects.new(VOLUME_OBJECT, vol)
    vol = obj.data
    vol.filepath = vdbs[first]
    # Blender only accepts a velocity grid name that the loaded file has:
    # load the first file as a single file, name the grid, then make it a sequence.
    vol.is_sequence = False
    vol.grids.load()
    if "v" in [g.name for g in vol.grids]:
        vol.velocity_grid = "v"
        vol.velocity_unit = "SECOND"
        vol.velocity_scale = 1.0
    vol.is_sequence = True
    # Blender shows file (scene_frame - frame_start + 1 + frame_offset)
    # for scene frames frame_start .. frame_start + frame_duration - 1.
    vol.frame_duration = last - first + 1
    vol.frame_start = first
    vol.frame_offset = first - 1
    vol.sequence_mode = "CLIP"
    # Cascade's VDBs are z-up scene coordinates; --vdb-y-up files (for Houdini)
    # are turned back like the y-up meshes: +90 degrees about x.
    obj.rotation_euler = (np.pi / 2, 0.0, 0.0) if vdb_up_axis(vdbs[first]) == "y" else (0.0, 0.0, 0.0)
    obj.hide_render = True
    _link(obj, scene)
    return obj


def import_cascade(out, load_volume_seq=True, fps_from_scene=True, file_normals=False,
                   motion_blur=False, scene=None):
    """Sets up OUT in `scene` (default: the context's); returns a dict with the
    objects, the frames found and the fps."""
    scene = scene or bpy.context.scene
    out = os.path.abspath(os.path.expanduser(out))
    meshes, vdbs = find_frames(out)
    if not meshes and not vdbs:
        raise FileNotFoundError(f"{out}: no mesh/fluid.NNNN.ply|obj nor surface/surface.NNNN.vdb")
    t0 = time.perf_counter()
    if fps_from_scene:
        fps = read_fps(out)
        scene.render.fps = max(1, int(round(fps)))
        scene.render.fps_base = scene.render.fps / fps
    frames = sorted(meshes) or sorted(vdbs)
    scene.frame_start, scene.frame_end = frames[0], frames[-1]
    # Handlers change mesh data while rendering; Blender asks for a locked UI then.
    scene.render.use_lock_interface = True
    if motion_blur:
        scene.render.use_motion_blur = True
    result = {"out": out, "mesh_frames": sorted(meshes), "vdb_frames": sorted(vdbs),
              "fps": scene.render.fps / scene.render.fps_base, "mesh": None, "volume": None}
    if meshes:
        obj = bpy.data.objects.get(MESH_OBJECT)
        if obj is None or obj.type != "MESH":
            obj = bpy.data.objects.new(MESH_OBJECT, bpy.data.meshes.new(MESH_OBJECT))
        obj["cascade_out"] = out
        obj["cascade_file_normals"] = int(bool(file_normals))
        _link(obj, scene)
        register_handler()
        _store_text_module()
        frame = scene.frame_current if frames[0] <= scene.frame_current <= frames[-1] else frames[0]
        scene.frame_current = frame
        update_fluid_object(obj, frame, force=True)
        result["mesh"] = obj
    if load_volume_seq and vdbs:
        result["volume"] = load_volume(out, vdbs, scene)
    print("cascade_import: %s: %d mesh frames (%s), %d VDB frames, frames %d-%d at %.6g fps, %.2f s"
          % (out, len(meshes), "-".join(str(f) for f in (frames[0], frames[-1])) if meshes else "none",
             len(vdbs), scene.frame_start, scene.frame_end, result["fps"], time.perf_counter() - t0))
    return result


def main(argv):
    import argparse
    ap = argparse.ArgumentParser(prog="blender -P cascade_import.py --",
                                 description="Load a Cascade output folder into Blender.")
    ap.add_argument("out", nargs="?", default=CASCADE_OUT)
    ap.add_argument("--no-volume", action="store_true", help="do not load surface/surface.####.vdb")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--fps-from-scene", action="store_true", help="fps from OUT/scene.json (default)")
    g.add_argument("--keep-fps", action="store_true", help="keep the Blender scene's fps")
    ap.add_argument("--file-normals", action="store_true",
                    help="use the files' normals as custom normals (slow: ~5 s a 1M-vertex frame); "
                         "default: Blender's smooth normals")
    ap.add_argument("--motion-blur", action="store_true", help="switch on render motion blur")
    a = ap.parse_args(argv)
    if not a.out:
        ap.error("no Cascade output folder: pass it after '--' or set CASCADE_OUT")
    return import_cascade(a.out,
                          load_volume_seq=LOAD_VOLUME and not a.no_volume,
                          fps_from_scene=FPS_FROM_SCENE and not a.keep_fps or a.fps_from_scene,
                          file_normals=FILE_NORMALS or a.file_normals,
                          motion_blur=MOTION_BLUR or a.motion_blur)


def _entry():
    """Blender runs this file with __name__ == "__main__" in three ways: -P
    (a file on disk, arguments after "--"), Run Script in the Text Editor, and
    as the registered text block when a saved .blend is opened (then __file__
    is "<file.blend>/cascade_import.py"): the last only re-installs the handler."""
    path = globals().get("__file__") or ""
    on_disk = os.path.isfile(path)
    space = getattr(bpy.context, "space_data", None)
    in_text_editor = getattr(space, "type", "") == "TEXT_EDITOR"
    if on_disk and "--" in sys.argv:
        main(sys.argv[sys.argv.index("--") + 1:])
    elif in_text_editor or (on_disk and CASCADE_OUT):
        if not CASCADE_OUT:  # an exception, not argparse's exit: that would close Blender
            raise RuntimeError("cascade_import: set CASCADE_OUT at the top of the script")
        main([])
    elif on_disk:
        print("cascade_import: no output folder: blender -P cascade_import.py -- OUT, "
              "or set CASCADE_OUT at the top of the script", file=sys.stderr)


# Always (also when Blender loads the text block with a saved .blend): keep the handler.
register_handler()

if __name__ == "__main__":
    _entry()
