"""blender_scene.py — what the scripts that drive the add-on inside Blender
share (tests/blender_addon.py, tests/blender_environment.py,
tests/blender_material.py, scripts/addon-window.py): reading the sample mesh,
installing the add-on from its zip, an empty scene in millimetres with one
selected mesh object, and what the .blend holds that the add-on might touch.
Blender runs those scripts with -P, so they import this file by putting its
folder on sys.path."""
import os

import bpy


def read_obj(path):
    """The vertices (x, y, z) and the faces (0-based vertex indices) of an OBJ
    file: enough of the format for the bundled samples."""
    verts, faces = [], []
    for line in open(path):
        t = line.split()
        if t and t[0] == "v":
            verts.append(tuple(float(x) for x in t[1:4]))
        elif t and t[0] == "f":
            faces.append(tuple(int(w.split("/")[0]) - 1 for w in t[1:]))
    return verts, faces


def install_addon(zip_path):
    """Install and enable the add-on from the build's ohm_blender.zip."""
    bpy.ops.preferences.addon_install(filepath=os.path.abspath(zip_path), overwrite=True)
    bpy.ops.preferences.addon_enable(module="ohm_blender")


def scene_with_mesh(name, verts, faces):
    """Remove every object, make 1 Blender unit 1 mm, and add the mesh as the
    active, selected object; returns (scene, object)."""
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    sc = bpy.context.scene
    sc.unit_settings.scale_length = 0.001
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(v) for v in verts], [], faces)
    me.update()
    obj = bpy.data.objects.new(name, me)
    sc.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    return sc, obj


def spot_with_lamp(mesh_path):
    """The sample mesh at 50 mm in an empty scene in millimetres (scene_with_mesh),
    and a 2e4 W point light, "lamp" (about 1.3 mW/mm^2 at 110 mm), at the
    origin: (scene, object, lamp object)."""
    import numpy as np
    verts, faces = read_obj(mesh_path)
    verts = np.array(verts)
    verts = (verts - verts.mean(axis=0)) * (50.0 / np.ptp(verts, axis=0).max())
    sc, obj = scene_with_mesh("spot", verts, faces)
    lamp = bpy.data.objects.new("lamp", bpy.data.lights.new("lamp", "POINT"))
    lamp.data.energy = 2.0e4
    sc.collection.objects.link(lamp)
    return sc, obj, lamp


def small_cycles(sc, size, samples, file_format):
    """Cycles at size x size pixels, `samples` samples, no denoising, in a
    black world (so that an image's mean is the objects' light alone)."""
    if sc.world is None:
        sc.world = bpy.data.worlds.new("black")
    sc.world.use_nodes, sc.world.color = False, (0.0, 0.0, 0.0)
    sc.render.engine = "CYCLES"
    sc.cycles.samples, sc.cycles.use_denoising = samples, False
    sc.render.resolution_x = sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.render.image_settings.file_format = file_format


def state():
    """What the .blend holds that ohm might touch: every material (users,
    nodes, links), every object's slots, modifiers, ohm's custom properties
    (a render adds Cycles' own) and attributes, the node groups."""
    def tree(nt):
        if nt is None:
            return None
        return (sorted((n.name, n.bl_idname) for n in nt.nodes),
                sorted((k.from_node.name, k.from_socket.identifier, k.to_node.name, k.to_socket.identifier)
                       for k in nt.links))
    return {"materials": {m.name: (m.users, m.use_nodes, tree(m.node_tree)) for m in bpy.data.materials},
            "objects": {o.name: ([s.material and s.material.name for s in o.material_slots],
                                 [m.name for m in o.modifiers], sorted(k for k in o.keys() if k.startswith("ohm")),
                                 sorted(a.name for a in o.data.attributes) if o.type == "MESH" else None)
                        for o in bpy.data.objects},
            "node_groups": sorted(g.name for g in bpy.data.node_groups)}


def differences(a, b):
    """What differs between two state()s, one line each."""
    return ["%s %s: %s -> %s" % (k, name, a[k].get(name), b[k].get(name))
            for k in ("materials", "objects") for name in sorted(set(a[k]) | set(b[k])) if a[k].get(name) != b[k].get(name)] + \
        (["node groups: %s -> %s" % (a["node_groups"], b["node_groups"])] if a["node_groups"] != b["node_groups"] else [])
