"""Render ohm's subsurface scattering with Cycles, headless, to a PNG.

  blender -b --factory-startup -P pipelines/blender/render.py -- \
      --vdb FILE.vdb --mesh MESH.obj --scale-mm S --out OUT.png \
      [--grid exitance_r,exitance_g,exitance_b | --grid fluence] \
      [--light-dir X,Y,Z] [--size W H] [--samples N] [--exposure E] \
      [--absorption A] [--sequence] [--save-blend FILE.blend] [--json REPORT.json]

WHAT IS SHOWN, AND WHY (option (a): the grid drives a volume's emission).
The volume object imports ohm's .vdb, and its Principled Volume emits light of
colour (grid_r, grid_g, grid_b) * exposure, read with Attribute nodes, and
absorbs with the `density` grid * --absorption (1/mm) so the front of the
object hides its back. No scattering and no lamps: the image is ohm's own
solution, not Cycles re-simulating subsurface transport. The alternative, (b) a
mesh coloured from the grid, is not possible in Blender 3.4 without pyopenvdb:
Python has no access to grid values and geometry nodes cannot sample a volume
grid before Blender 4.x, so the colours would have to be baked outside
Blender. The exitance grid (W/mm^2 leaving each boundary cell) is a shell one
voxel thick on the surface, so it renders as a glowing skin, which is what a
subsurface-scattering render looks like from outside. --grid fluence shows the
light inside instead. A single name X that the file lacks but X_r, X_g, X_b
exist is taken as those three.

The mesh (its OBJ coordinates times --scale-mm, ohm's mesh_scale_mm from the
stats JSON, so in ohm's millimetres; Blender 3.4 cannot read the grids'
ohm_mesh_scale_mm metadata) frames the camera and is kept in the scene hidden
from the render; the report gives its box next to the volume's, so a wrong
--scale-mm shows. 1 Blender unit = 1 mm (scene unit scale 0.001).

The half-voxel offset: Blender 3.4 renders voxel (i,j,k) over index cell
[i,i+1]^3, OpenVDB (and ohm) centre it on (i,j,k). The volume object is moved
by -h/2 on each axis. h is ohm_voxel_size_mm, read here from the diagonal of
the grid's index-to-object matrix (the same number: Blender 3.4 has no Python
access to grid metadata). Render > Clipping is set to 0 so faint leaves are
not culled (docs/blender.md, "Precision").

The camera looks from the lit side, turned 50 degrees off the light's
direction (--light-dir: ohm's dir=, the direction the light travels) towards
the world axis most perpendicular to it, so that the lit half of the object is
on the RIGHT half of the image and the far half on the left. The world is a
neutral grey and the film is transparent: background pixels have alpha 0.

--sequence imports every sibling NAME_<digits>.vdb (as ohm's orbit= writes
them) as one Blender sequence and renders each frame to OUT_0001.png ...

The JSON report (--json) holds the grids Blender lists, is_loaded,
error_message, the requested grids and which are missing, the boxes, the
offset applied, the camera, the images written, the render times, the
problems, and "ok". sys.exit's code is not propagated by every Blender, so
callers should read "ok" from the JSON.
"""
import json
import math
import os
import re
import sys
import time
import traceback

import bpy
import mathutils


def parse_args(argv):
    a = {"vdb": None, "mesh": None, "scale_mm": None, "out": None,
         "grid": "exitance_r,exitance_g,exitance_b", "light_dir": "0,-1,-1",
         "size": (320, 240), "samples": 16, "exposure": 0.5, "absorption": 0.3,
         "sequence": False, "json": None, "save_blend": None}
    i = 0
    while i < len(argv):
        k = argv[i]
        def val(n=1):
            if i + n >= len(argv):
                raise SystemExit("render.py: %s needs %d value(s)" % (k, n))
            return argv[i + 1:i + 1 + n]
        if k == "--vdb":
            a["vdb"] = val()[0]; i += 2
        elif k == "--mesh":
            a["mesh"] = val()[0]; i += 2
        elif k == "--scale-mm":
            a["scale_mm"] = float(val()[0]); i += 2
        elif k == "--out":
            a["out"] = val()[0]; i += 2
        elif k == "--grid":
            a["grid"] = val()[0]; i += 2
        elif k == "--light-dir":
            a["light_dir"] = val()[0]; i += 2
        elif k == "--size":
            w, h = val(2); a["size"] = (int(w), int(h)); i += 3
        elif k == "--samples":
            a["samples"] = int(val()[0]); i += 2
        elif k == "--exposure":
            a["exposure"] = float(val()[0]); i += 2
        elif k == "--absorption":
            a["absorption"] = float(val()[0]); i += 2
        elif k == "--sequence":
            a["sequence"] = True; i += 1
        elif k == "--json":
            a["json"] = val()[0]; i += 2
        elif k == "--save-blend":
            a["save_blend"] = val()[0]; i += 2
        else:
            raise SystemExit("render.py: unknown argument %r" % k)
    for need in ("vdb", "mesh", "scale_mm", "out"):
        if a[need] is None:
            raise SystemExit("render.py: --%s is required" % need.replace("_", "-"))
    d = [float(t) for t in a["light_dir"].split(",")]
    if len(d) != 3 or sum(x * x for x in d) == 0:
        raise SystemExit("render.py: --light-dir needs X,Y,Z, not all 0")
    a["light_dir"] = d
    return a


def read_obj(path, scale):
    """Vertices (times scale) and faces of an OBJ, with no axis conversion:
    ohm reads the file's coordinates as they are."""
    verts, faces = [], []
    with open(path) as f:
        for line in f:
            t = line.split()
            if not t:
                continue
            if t[0] == "v":
                verts.append(tuple(float(x) * scale for x in t[1:4]))
            elif t[0] == "f":
                idx = []
                for w in t[1:]:
                    n = int(w.split("/")[0])
                    idx.append(n - 1 if n > 0 else len(verts) + n)
                faces.append(idx)
    return verts, faces


def world_box(obj):
    dg = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    pts = [ev.matrix_world @ mathutils.Vector(c) for c in ev.bound_box]
    return ([min(p[i] for p in pts) for i in range(3)],
            [max(p[i] for p in pts) for i in range(3)])


def sequence_files(path):
    d, base = os.path.split(os.path.abspath(path))
    m = re.match(r"^(.*?)(\d+)(\.vdb)$", base)
    if not m:
        return d, [base]
    pat = re.compile("^" + re.escape(m.group(1)) + r"\d+" + re.escape(m.group(3)) + "$")
    return d, sorted(f for f in os.listdir(d) if pat.match(f))


def build_material(names, exposure, absorption):
    mat = bpy.data.materials.new("ohm_emission")
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    pv = nt.nodes.new("ShaderNodeVolumePrincipled")
    nt.links.new(pv.outputs["Volume"], out.inputs["Volume"])
    pv.inputs["Color"].default_value = (0, 0, 0, 1)       # no scattering
    pv.inputs["Absorption Color"].default_value = (0, 0, 0, 1)
    pv.inputs["Density"].default_value = absorption
    pv.inputs["Density Attribute"].default_value = "density"
    pv.inputs["Emission Strength"].default_value = exposure
    pv.inputs["Emission Color"].default_value = (0, 0, 0, 1)
    attrs = []
    for n in names:
        at = nt.nodes.new("ShaderNodeAttribute")
        at.attribute_name = n
        attrs.append(at)
    if len(attrs) == 1:
        nt.links.new(attrs[0].outputs["Fac"], pv.inputs["Emission Color"])
    else:
        comb = nt.nodes.new("ShaderNodeCombineColor")
        for at, ch in zip(attrs, ("Red", "Green", "Blue")):
            nt.links.new(at.outputs["Fac"], comb.inputs[ch])
        nt.links.new(comb.outputs["Color"], pv.inputs["Emission Color"])
    return mat


def look_from(light_dir, centre, radius, aspect):
    """Camera turned 60 degrees from -light_dir towards the world axis most
    perpendicular to the light; image right = the lit side."""
    L = mathutils.Vector(light_dir).normalized()
    toward = -L
    axes = [mathutils.Vector(v) for v in ((0, 1, 0), (0, 0, 1), (1, 0, 0))]
    p = min(axes, key=lambda v: abs(v.dot(L)))
    p = (p - p.dot(toward) * toward).normalized()
    th = math.radians(50.0)
    v = (toward * math.cos(th) + p * math.sin(th)).normalized()   # object -> camera
    right = (toward - toward.dot(v) * v).normalized()
    up = v.cross(right)
    rot = mathutils.Matrix((right, up, v)).transposed()          # columns
    fov = 2 * math.atan(18.0 / 50.0)                              # 50 mm lens, 36 mm sensor
    # sensor fit AUTO: the longer image side gets the full field of view
    fov_min = 2 * math.atan(math.tan(fov / 2) * min(aspect, 1 / aspect))
    dist = 1.0 * radius / math.sin(fov_min / 2)
    loc = mathutils.Vector(centre) + v * dist
    return loc, rot.to_euler(), dist


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    a = parse_args(argv)
    rep = {"blender": bpy.app.version_string, "vdb": a["vdb"], "mesh": a["mesh"],
           "scale_mm": a["scale_mm"], "problems": [], "images": [], "render_seconds": []}
    try:
        render(a, rep)
    except Exception:
        rep["problems"].append("exception: " + traceback.format_exc())
    rep["ok"] = not rep["problems"]
    text = json.dumps(rep, indent=1)
    if a["json"]:
        tmp = a["json"] + ".tmp"
        with open(tmp, "w") as f:
            f.write(text + "\n")
        os.replace(tmp, a["json"])
    else:
        print("RENDER_JSON: " + json.dumps(rep))
    for p in rep["problems"]:
        print("render.py: %s" % p, file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    sys.exit(0 if rep["ok"] else 1)


def render(a, rep):
    # factory scene: empty it
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o, do_unlink=True)
    sc = bpy.context.scene
    sc.unit_settings.system = 'METRIC'
    sc.unit_settings.scale_length = 0.001
    sc.unit_settings.length_unit = 'MILLIMETERS'

    # the mesh, in ohm's millimetres
    verts, faces = read_obj(a["mesh"], a["scale_mm"])
    me = bpy.data.meshes.new("ohm_mesh")
    me.from_pydata(verts, [], faces)
    me.update()
    mesh_obj = bpy.data.objects.new("ohm_mesh", me)
    sc.collection.objects.link(mesh_obj)
    mesh_obj.hide_render = True
    mlo = [min(v[i] for v in verts) for i in range(3)]
    mhi = [max(v[i] for v in verts) for i in range(3)]
    rep["mesh_box"] = {"min": mlo, "max": mhi}

    # the volume: one file, or a sequence of siblings
    vdb = os.path.abspath(a["vdb"])
    d, files = (sequence_files(vdb) if a["sequence"] else (os.path.dirname(vdb), [os.path.basename(vdb)]))
    rep["files"] = files
    vol = bpy.data.volumes.new("ohm_volume")
    vol.filepath = os.path.join(d, files[0])
    if a["sequence"] and len(files) > 1:
        vol.is_sequence = True
        vol.frame_start = 1
        vol.frame_duration = len(files)
        vol.frame_offset = int(re.search(r"(\d+)\.vdb$", files[0]).group(1)) - 1
        vol.sequence_mode = 'CLIP'
    vol.render.clipping = 0.0
    vol.render.space = 'OBJECT'
    vobj = bpy.data.objects.new("ohm_volume", vol)
    sc.collection.objects.link(vobj)
    sc.frame_set(1)
    vol.grids.load()
    rep["is_loaded"] = bool(vol.grids.is_loaded)
    rep["error_message"] = vol.grids.error_message
    if vol.grids.error_message:
        rep["problems"].append("Blender: grid error: " + vol.grids.error_message)
    if not vol.grids.is_loaded:
        rep["problems"].append("Blender did not load the grids")
    names = [g.name for g in vol.grids]
    rep["grids"] = names
    print("render.py: Blender lists grids: " + ", ".join(names))

    want = [s for s in a["grid"].split(",") if s]
    if len(want) == 1 and want[0] not in names and all(want[0] + s in names for s in ("_r", "_g", "_b")):
        want = [want[0] + s for s in ("_r", "_g", "_b")]
    if len(want) not in (1, 3):
        raise ValueError("--grid takes one name or three (r,g,b), got %r" % a["grid"])
    rep["grid_used"] = want
    rep["missing_grids"] = [n for n in want if n not in names]
    if rep["missing_grids"]:
        rep["problems"].append("grids not in the file: " + ", ".join(rep["missing_grids"]))
    if "density" not in names:
        rep["problems"].append("no density grid: the volume will not absorb")

    # half-voxel offset: h from the index-to-object matrix of a grid
    h = None
    for g in vol.grids:
        m = g.matrix_object
        h = float(m[0][0])
        break
    if h is None:
        raise ValueError("the volume has no grids")
    rep["voxel_mm"] = h
    vobj.location = (-0.5 * h,) * 3
    rep["offset_applied"] = [-0.5 * h] * 3
    vlo, vhi = world_box(vobj)
    rep["volume_box"] = {"min": vlo, "max": vhi}
    # the mesh lies inside the volume's (leaf-aligned) box, give or take a voxel
    for i in range(3):
        if mlo[i] < vlo[i] - h or mhi[i] > vhi[i] + h:
            rep["problems"].append("the mesh (x --scale-mm) is not inside the volume's box on axis %d: "
                                   "mesh %.3g..%.3g, volume %.3g..%.3g" % (i, mlo[i], mhi[i], vlo[i], vhi[i]))
            break

    vobj.data.materials.append(build_material(want, a["exposure"], a["absorption"]))

    # world: neutral grey; film transparent
    world = bpy.data.worlds.new("ohm_world")
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1)
    bg.inputs["Strength"].default_value = 0.2
    sc.world = world

    # camera
    W, H = a["size"]
    centre = [(mlo[i] + mhi[i]) / 2 for i in range(3)]
    radius = 0.5 * math.sqrt(sum((mhi[i] - mlo[i]) ** 2 for i in range(3)))
    loc, rot, dist = look_from(a["light_dir"], centre, radius, W / H)
    cam = bpy.data.cameras.new("ohm_camera")
    cam.lens = 50
    cam.sensor_width = 36
    cam.sensor_fit = 'AUTO'
    cam.clip_start = max(0.01, dist - 2 * radius)
    cam.clip_end = dist + 2 * radius
    cobj = bpy.data.objects.new("ohm_camera", cam)
    cobj.location = loc
    cobj.rotation_euler = rot
    sc.collection.objects.link(cobj)
    sc.camera = cobj
    rep["camera"] = {"location": list(loc), "distance_mm": dist, "light_dir": a["light_dir"],
                     "lit_side_in_image": "right"}

    # Cycles, few samples, PNG
    sc.render.engine = 'CYCLES'
    sc.cycles.device = 'CPU'
    sc.cycles.samples = a["samples"]
    sc.cycles.use_denoising = False
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.volume_step_rate = 1.0
    sc.cycles.max_bounces = 0
    sc.render.resolution_x = W
    sc.render.resolution_y = H
    sc.render.resolution_percentage = 100
    sc.render.film_transparent = True
    sc.render.dither_intensity = 0.0
    sc.view_settings.view_transform = 'Standard'
    sc.view_settings.look = 'None'
    sc.render.image_settings.file_format = 'PNG'
    sc.render.image_settings.color_mode = 'RGBA'
    sc.render.image_settings.color_depth = '8'

    if a["save_blend"]:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(a["save_blend"]))

    out = os.path.abspath(a["out"])
    frames = [1]
    if a["sequence"] and len(files) > 1:
        frames = list(range(1, len(files) + 1))
    for f in frames:
        sc.frame_set(f)
        path = out
        if len(frames) > 1:
            root, ext = os.path.splitext(out)
            path = "%s_%04d%s" % (root, f, ext or ".png")
        sc.render.filepath = path
        t0 = time.time()
        bpy.ops.render.render(write_still=True)
        rep["render_seconds"].append(round(time.time() - t0, 3))
        if not os.path.isfile(path):
            rep["problems"].append("no image written: " + path)
        rep["images"].append(path)
        print("render.py: wrote %s (%.1f s)" % (path, rep["render_seconds"][-1]))


main()
