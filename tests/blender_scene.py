"""blender_scene.py — what the scripts that drive the add-on inside Blender
share (tests/blender_addon.py, tests/blender_environment.py,
scripts/addon-window.py): reading the sample mesh, installing the add-on from
its zip, and an empty scene in millimetres with one selected mesh object.
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
