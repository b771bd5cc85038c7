"""Open ohm's .vdb files in Blender the way a user does and report what Blender sees.

Run inside Blender (3.4 API; no pyopenvdb inside Blender 3.4):

  blender -b --factory-startup -P pipelines/blender/import_check.py -- \
      --vdb FILE [--sequence] [--expect-grids a,b,c] [--mesh GRID:THRESHOLD] \
      [--vdb FILE2 ...] [--json OUT]

Every --vdb starts one check; --sequence, --expect-grids and --mesh after it
belong to that check, so several checks share one Blender start-up (a few
seconds each). --json is global; without it the JSON goes to stdout on one line
that starts with "IMPORT_CHECK_JSON: ".

Each check imports with File > Import > OpenVDB's operator
(bpy.ops.object.volume_import) at the world origin, then calls
volume.grids.load() and records what follows. When the operator refuses a
file (it drops a volume that fails to load, with only a warning), the file is
loaded directly with bpy.data.volumes.new + filepath to get Blender's
grids.error_message.

  grids          name, data_type, channels and matrix_object (index -> object,
                 row-major) of every grid, as Blender reports them
  is_loaded, error_message   from volume.grids
  missing_grids / unexpected_grids   against --expect-grids (exact set)
  bbox_world     the object's bounding box: obj.bound_box (evaluated object)
                 mapped through matrix_world. In Blender 3.4 this is the union
                 over grids of each grid's *leaf-node* box (8^3 voxel blocks),
                 with its integer index corners mapped by the grid transform,
                 i.e. OpenVDB index points (cell centres), not voxel faces.
  mesh           with --mesh GRID:T: Blender's own Volume to Mesh modifier on
                 a helper mesh object (resolution Grid, adaptivity 0): vertex
                 count and world box. Blender 3.4 adds voxel_size/2 to every
                 vertex that OpenVDB's volumeToMesh returns (its comment:
                 "better align generated mesh with volume", T85312), because
                 its renderers put voxel (i,j,k) at index (i,j,k)+1/2. This
                 script reports the mesh as Blender makes it, offset included.

With --sequence the file is taken as one frame of NAME_0001.vdb, NAME_0002.vdb
...: every sibling NAME_<digits>.vdb in its directory is passed to the import
operator, as if all were selected in the file browser, and Blender's own
sequence detection sets is_sequence, frame_start, frame_duration and
frame_offset. frames_seen is that frame_duration. Then scene.frame_set(k) for
every frame from frame_start - 1 to the last frame + 1, and for each the
evaluated volume's grids.frame_filepath, is_loaded, grid names, box and mesh.

The process exits 1 when any check has a problem, 0 otherwise (and 2 on bad
arguments). Callers should still read the JSON: its "ok" fields are the
contract, and a missing JSON file means Blender itself failed.
"""
import json
import os
import re
import sys
import traceback

import bpy
import mathutils


def parse_args(argv):
    args = argv[argv.index("--") + 1:] if "--" in argv else []
    checks, out = [], None
    i = 0

    def value():
        nonlocal i
        if i + 1 >= len(args):
            raise SystemExit("import_check: %s needs a value" % args[i])
        i += 1
        return args[i]

    while i < len(args):
        a = args[i]
        if a == "--vdb":
            checks.append({"vdb": os.path.abspath(value()), "sequence": False,
                           "expect_grids": None, "mesh": None})
        elif a == "--json":
            out = value()
        elif a in ("--sequence", "--expect-grids", "--mesh"):
            if not checks:
                raise SystemExit("import_check: %s must follow a --vdb" % a)
            if a == "--sequence":
                checks[-1]["sequence"] = True
            elif a == "--expect-grids":
                checks[-1]["expect_grids"] = [g for g in value().split(",") if g]
            else:
                grid, _, thr = value().rpartition(":")
                try:
                    checks[-1]["mesh"] = (grid, float(thr))
                except ValueError:
                    raise SystemExit("import_check: --mesh wants GRID:THRESHOLD")
                if not grid:
                    raise SystemExit("import_check: --mesh wants GRID:THRESHOLD")
        else:
            raise SystemExit("import_check: unknown argument %r" % a)
        i += 1
    if not checks:
        raise SystemExit("import_check: give at least one --vdb FILE")
    return checks, out


def clear_scene():
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o, do_unlink=True)
    for coll in (bpy.data.meshes, bpy.data.volumes):
        for d in list(coll):
            if d.users == 0:
                coll.remove(d)


def sequence_files(path):
    """Siblings NAME_<digits>.vdb of PATH, sorted by number."""
    d, base = os.path.split(path)
    m = re.match(r"^(.*?)(\d+)\.vdb$", base, re.IGNORECASE)
    if not m:
        return None
    pat = re.compile(r"^" + re.escape(m.group(1)) + r"(\d+)\.vdb$", re.IGNORECASE)
    found = [(int(pat.match(f).group(1)), f) for f in os.listdir(d or ".") if pat.match(f)]
    return [f for _, f in sorted(found)]


def import_volume(path, files):
    """The import operator at the world origin; returns the new volume objects."""
    before = set(bpy.data.objects)
    d = os.path.dirname(path) + os.sep
    res = bpy.ops.object.volume_import(filepath=path, directory=d,
                                       files=[{"name": f} for f in files],
                                       align='WORLD', location=(0.0, 0.0, 0.0),
                                       rotation=(0.0, 0.0, 0.0))
    new = [o for o in bpy.data.objects if o not in before and o.type == 'VOLUME']
    return res, new


def world_box(obj):
    pts = [obj.matrix_world @ mathutils.Vector(c) for c in obj.bound_box]
    return {"min": [min(p[i] for p in pts) for i in range(3)],
            "max": [max(p[i] for p in pts) for i in range(3)]}


def describe_grids(vol):
    out = []
    for g in vol.grids:
        out.append({"name": g.name, "data_type": g.data_type, "channels": g.channels,
                    "matrix_object": [list(r) for r in g.matrix_object]})
    return out


def mesh_of(mesh_obj):
    dg = bpy.context.evaluated_depsgraph_get()
    me_obj = mesh_obj.evaluated_get(dg)
    me = me_obj.to_mesh()
    try:
        vs = [me_obj.matrix_world @ v.co for v in me.vertices]
        r = {"vertices": len(vs), "faces": len(me.polygons)}
        if vs:
            r["min"] = [min(v[i] for v in vs) for i in range(3)]
            r["max"] = [max(v[i] for v in vs) for i in range(3)]
        return r
    finally:
        me_obj.to_mesh_clear()


def grid_problems(names, expect):
    if expect is None:
        return [], [], []
    missing = [g for g in expect if g not in names]
    unexpected = [g for g in names if g not in expect]
    probs = []
    if missing:
        probs.append("missing grids: " + ",".join(missing))
    if unexpected:
        probs.append("unexpected grids: " + ",".join(unexpected))
    return missing, unexpected, probs


def snapshot(obj, mesh_obj, expect):
    """What the evaluated volume holds at the scene's current frame."""
    dg = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    vol = ev.data
    vol.grids.load()
    names = [g.name for g in vol.grids]
    r = {"frame": bpy.context.scene.frame_current,
         "grids_frame": vol.grids.frame,
         "frame_filepath": vol.grids.frame_filepath,
         "is_loaded": bool(vol.grids.is_loaded),
         "error_message": vol.grids.error_message,
         "grids": describe_grids(vol),
         "grid_names": names,
         "bbox_world": world_box(ev) if names else None}
    r["missing_grids"], r["unexpected_grids"], r["problems"] = grid_problems(names, expect)
    if mesh_obj is not None:
        r["mesh"] = mesh_of(mesh_obj)
    return r


def run_check(c):
    clear_scene()
    scene = bpy.context.scene
    scene.frame_set(1)
    r = {"vdb": c["vdb"], "sequence": c["sequence"], "expect_grids": c["expect_grids"],
         "problems": []}
    if not os.path.isfile(c["vdb"]):
        r["problems"].append("no such file: " + c["vdb"])
    files = [os.path.basename(c["vdb"])]
    if c["sequence"]:
        seq = sequence_files(c["vdb"])
        if not seq:
            r["problems"].append("--sequence: %s is not NAME_<digits>.vdb" % c["vdb"])
        else:
            files = seq
    r["files"] = files
    if r["problems"]:
        return r

    res, objs = import_volume(c["vdb"], files)
    r["operator"] = sorted(res)
    r["objects"] = len(objs)
    if 'FINISHED' not in res or not objs:
        r["problems"].append("volume_import did not create a volume object: %s" % sorted(res))
        # The operator drops a volume that fails to load and only warns.
        # Load it directly to get Blender's own error message.
        vol = bpy.data.volumes.new("import_check_direct")
        vol.filepath = c["vdb"]
        vol.grids.load()
        r["is_loaded"] = bool(vol.grids.is_loaded)
        r["error_message"] = vol.grids.error_message
        r["grids"] = describe_grids(vol)
        r["grid_names"] = [g["name"] for g in r["grids"]]
        if vol.grids.error_message:
            r["problems"].append("grid error: " + vol.grids.error_message)
        return r
    if len(objs) != 1:
        r["problems"].append("import made %d volume objects, expected 1" % len(objs))
    obj = objs[0]
    vol = obj.data
    r["matrix_world"] = [list(row) for row in obj.matrix_world]
    r["volume"] = {"filepath": vol.filepath, "is_sequence": bool(vol.is_sequence),
                   "frame_start": vol.frame_start, "frame_duration": vol.frame_duration,
                   "frame_offset": vol.frame_offset, "sequence_mode": vol.sequence_mode,
                   "render_precision": vol.render.precision, "render_clipping": vol.render.clipping,
                   "render_space": vol.render.space}

    mesh_obj = None
    if c["mesh"]:
        grid, thr = c["mesh"]
        mesh_obj = bpy.data.objects.new("import_check_mesh", bpy.data.meshes.new("import_check_mesh"))
        scene.collection.objects.link(mesh_obj)
        m = mesh_obj.modifiers.new("volume_to_mesh", 'VOLUME_TO_MESH')
        m.object = obj
        m.grid_name = grid
        m.threshold = thr
        m.resolution_mode = 'GRID'
        m.adaptivity = 0.0
        r["mesh_request"] = {"grid": grid, "threshold": thr}

    if not c["sequence"]:
        s = snapshot(obj, mesh_obj, c["expect_grids"])
        for k in ("is_loaded", "error_message", "grids", "grid_names", "bbox_world",
                  "missing_grids", "unexpected_grids", "mesh", "frame_filepath"):
            if k in s:
                r[k] = s[k]
        r["problems"] += s["problems"]
        if not s["is_loaded"]:
            r["problems"].append("grids not loaded")
        if s["error_message"]:
            r["problems"].append("grid error: " + s["error_message"])
        if mesh_obj is not None and not s["mesh"]["vertices"]:
            r["problems"].append("volume to mesh of %s gave no vertices" % c["mesh"][0])
        return r

    # a sequence: what Blender detected, then every frame (and one either side)
    r["frames_seen"] = vol.frame_duration if vol.is_sequence else 0
    if not vol.is_sequence:
        r["problems"].append("Blender did not detect a sequence in %d files" % len(files))
        return r
    if r["frames_seen"] != len(files):
        # Blender 3.4 keeps the first run of consecutive numbers and drops
        # the rest without a word
        r["problems"].append("Blender sees %d frames of %d files (a gap in the numbering?)"
                             % (r["frames_seen"], len(files)))
    first, last = vol.frame_start, vol.frame_start + vol.frame_duration - 1
    r["frames"] = []
    loaded = 0
    for k in range(first - 1, last + 2):
        scene.frame_set(k)
        s = snapshot(obj, mesh_obj, c["expect_grids"] if first <= k <= last else None)
        r["frames"].append(s)
        inside = first <= k <= last
        if s["is_loaded"] and s["grid_names"]:
            loaded += 1
        if inside:
            for p in s["problems"]:
                r["problems"].append("frame %d: %s" % (k, p))
            if not s["is_loaded"]:
                r["problems"].append("frame %d: grids not loaded" % k)
            if s["error_message"]:
                r["problems"].append("frame %d: grid error: %s" % (k, s["error_message"]))
    r["frames_loaded"] = loaded
    # the shared fields, as at the first frame
    scene.frame_set(first)
    s = snapshot(obj, None, None)
    for k in ("is_loaded", "error_message", "grids", "grid_names", "bbox_world"):
        r[k] = s[k]
    return r


def main():
    try:
        checks, out = parse_args(sys.argv)
    except SystemExit as e:
        print(e, file=sys.stderr)
        sys.stdout.flush()
        os._exit(2)
    results = []
    for c in checks:
        try:
            r = run_check(c)
        except Exception:
            r = {"vdb": c["vdb"], "problems": ["exception: " + traceback.format_exc()]}
        r["ok"] = not r["problems"]
        results.append(r)
    doc = {"blender": bpy.app.version_string, "ok": all(r["ok"] for r in results),
           "checks": results}
    text = json.dumps(doc, indent=1)
    if out:
        tmp = out + ".tmp"
        with open(tmp, "w") as f:
            f.write(text + "\n")
        os.replace(tmp, out)
    else:
        print("IMPORT_CHECK_JSON: " + json.dumps(doc))
    for r in results:
        for p in r["problems"]:
            print("import_check: %s: %s" % (r["vdb"], p), file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    # sys.exit inside Blender is honoured by 3.4 but not by every version;
    # callers read "ok" from the JSON rather than trust this.
    sys.exit(0 if doc["ok"] else 1)


main()
