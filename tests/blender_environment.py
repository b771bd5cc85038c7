"""blender_environment.py — the World as ohm's environment light, through the
add-on in a headless Blender (tests/cli_light_environment.sh):

  blender -b --factory-startup --python-exit-code 1 -P tests/blender_environment.py -- ZIP MESH OUTDIR

Installs the add-on from its zip, builds MESH (an OBJ, 1 Blender unit = 1 mm)
with no lamps, and:
  - with World.ohm_light off, Solve refuses: the scene has no light;
  - "colour": a World of one colour (no nodes) lights it: Solve (marble,
    24 cells, shadows), and the light the add-on made is type=environment
    with the colour as its radiance;
  - "sky": the World's nodes, an Environment Texture of an image this script
    writes (OUTDIR/sky.exr: bright above, towards -y) into the Background:
    Solve, and the add-on's light names the image as sky=.
For each it writes OUTDIR/NAME.json (the light's options) and
OUTDIR/NAME.npy (the fluence per channel, [c, k, j, i]); and OUTDIR/mesh.obj,
the vertices exactly as Blender holds them, for the command line and Python to
solve the same scene.  Any failed check raises, so Blender exits 1."""
import json
import os
import sys

import bpy
import numpy as np

ZIP, MESH, OUT = sys.argv[sys.argv.index("--") + 1:][:3]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_scene import install_addon, read_obj, scene_with_mesh  # noqa: E402


install_addon(ZIP)
from ohm_blender import bridge, session  # noqa: E402  (installed just now)

verts, faces = read_obj(MESH)
sc, obj = scene_with_mesh("object", verts, faces)
obj.ohm.preset = "marble"
obj.ohm.dim = 24
obj.ohm.solver = "direct"
obj.ohm.shadows = True

# the mesh exactly as the add-on hands it to the library (its triangles, its
# vertices in mm: a unit of 0.001 m is 1.0000000475 mm in Blender's float32),
# written so that it reads back exactly
local, tris = bridge.evaluated_mesh(obj, bpy.context.evaluated_depsgraph_get())
with open(os.path.join(OUT, "mesh.obj"), "w") as f:
    for v in bridge.world_mm(obj, local, bridge.mm_per_unit(sc, obj)):
        f.write("v %r %r %r\n" % tuple(float(x) for x in v))
    for t in tris:
        f.write("f %d %d %d\n" % tuple(int(i) + 1 for i in t))

if sc.world is None:
    sc.world = bpy.data.worlds.new("World")
world = sc.world

# the World does not light the object unless asked
world.ohm_light = False
try:
    refused, why = bpy.ops.ohm.solve() == {"CANCELLED"}, ""
except RuntimeError as e:  # an operator's error report, raised in the background
    refused, why = True, str(e)
why += session.get(obj).status if session.get(obj) else ""
assert refused and "World" in why, "Solve with no lamp and World.ohm_light off: refused %s, %r" % (refused, why)


def solve(name):
    lights = bridge.scene_lights(sc, bridge.mm_per_unit(sc, obj))
    assert len(lights) == 1 and lights[0]["type"] == "environment", lights
    assert bpy.ops.ohm.solve() == {"FINISHED"}, "Solve did not finish: %s" % session.get(obj).status
    s = session.get(obj)
    assert s is not None and s.scene is not None, "no solved scene: %s" % (s.status if s else "no session")
    r = s.scene.result()
    fluence = np.stack([s.scene.fluence(channel=c) for c in range(r["channels"])])
    np.save(os.path.join(OUT, name + ".npy"), fluence)
    with open(os.path.join(OUT, name + ".json"), "w") as f:
        json.dump(lights[0], f)
    print("%s: light %s, power in %.6g W, fluence max %.6g" % (name, lights[0], r["power_in"], fluence.max()))
    return lights[0]


# a World of one colour
world.use_nodes = False
world.color = (0.8, 0.5, 0.3)
world.ohm_light = True
light = solve("colour")
expect = np.array(world.color[:3], dtype=np.float64) * 1e-6
assert np.allclose(light["intensity"], expect, rtol=1e-12, atol=0), (light, expect)
assert "sky" not in light

# an Environment Texture: bright above and towards -y (the image's top right quadrant)
W, H = 32, 16
px = np.full((H, W, 4), 0.05, dtype=np.float32)
px[:, :, 3] = 1
px[H // 2:, W // 2:, :3] = 1.0  # Blender's rows go up from the bottom: the top half is rows H/2..H
img = bpy.data.images.new("sky", W, H, float_buffer=True)
img.pixels.foreach_set(px.ravel())
sky_path = os.path.join(OUT, "sky.exr")
img.filepath_raw = sky_path
img.file_format = "OPEN_EXR"
img.save()
world.use_nodes = True
nodes, links = world.node_tree.nodes, world.node_tree.links
bg = next(n for n in nodes if n.type == "BACKGROUND")
tex = nodes.new("ShaderNodeTexEnvironment")
tex.image = bpy.data.images.load(sky_path)
links.new(tex.outputs["Color"], bg.inputs["Color"])
bg.inputs["Strength"].default_value = 2.0
light = solve("sky")
assert os.path.samefile(light["sky"], sky_path), light
assert np.allclose(light["intensity"], 2e-6, rtol=1e-12, atol=0), light

# an image with no file of its own (generated here; a packed one alike): refused, naming the image
tex.image = bpy.data.images.new("painted sky", 8, 4, float_buffer=True)
try:
    refused, why = bpy.ops.ohm.solve() == {"CANCELLED"}, ""
except RuntimeError as e:
    refused, why = True, str(e)
why += session.get(obj).status if session.get(obj) else ""
assert refused and "'painted sky' is packed or generated" in why, \
    "Solve with a generated sky image: refused %s, %r" % (refused, why)
print("blender_environment: ok")
