"""blender_material.py — the artist's material and a bake's renders
(tests/cli_blender_material.sh), headless:

  blender -b --factory-startup --python-exit-code 1 -P tests/blender_material.py -- \
      ZIP MESH OUTDIR REPORT.json material
  blender -b --factory-startup OUTDIR/material.blend -f 1,10,20 --python-exit-code 1 \
      -P tests/blender_material.py -- - - OUTDIR REPORT.json reopen

MODE material: Spot (50 mm, 1 unit = 1 mm) with the artist's own material
"MyHandmadeSkin" (a node tree with a node named "my skin"), shared with a
second object; a point light.  Solve keeps the material, its nodes and its
users, and a Cycles render of the second object is as before; Ctrl-Z after
Solve gives back the scene exactly; Show result off renders the artist's
shader again; Remove ohm result leaves the scene as it was before Solve.
Then Live relight and a 20-frame Bake of the light's power keyframed
1 -> 0.5 -> 1 with Volume object: the status counts frames 1 to 20 of 20;
Cycles renders of frames 1, 10 and 20, the test wiring nothing (a black
world, ohm's emission alone), have mean brightness ratios equal to the
power's within 2%, of the object and of the volume object alone (and,
as a CONTROL, alike without ohm's frames modifier).  Then a bake of frames
21-24 where nothing changes: one file, linked for the other frames, and a
sequence volume that renders them.  Saves
OUTDIR/material.blend, to render frames 1, 10, 20 as OUTDIR/frame_FFFF.exr.

MODE reopen: in that file, reopened by a Blender without the add-on (the
renders of -f ran before this script): the material is there with its
nodes and users, and the renders' ratios are the power's.
Any failed check raises, so Blender exits 1."""
import json
import os
import sys

import bpy
import numpy as np

args = sys.argv[sys.argv.index("--") + 1:]
ZIP, MESH, OUT, REPORT, MODE = args[:5]
DIM = 32
FRAMES = (1, 10, 20)
POWER = {1: 1.0, 10: 0.5, 20: 1.0}  # the light's power keyframes, times its watts
ARTIST, ARTIST_NODE = "MyHandmadeSkin", "my skin"
ARTIST_SAMPLES = 256
report = {"mode": MODE, "problems": []}
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_scene import differences, install_addon, small_cycles, spot_with_lamp, state  # noqa: E402


def problem(text):
    report["problems"].append(text)
    print("PROBLEM:", text)


def exr_mean(path):
    """The mean of (r + g + b) / 3 over a linear EXR render's pixels."""
    img = bpy.data.images.load(path)
    px = np.array(img.pixels[:], dtype=np.float64).reshape(-1, 4)
    bpy.data.images.remove(img)
    return float(px[:, :3].mean())


def ratios_checked(what, means):
    """Each frame's mean over frame 1's, against the power's ratio."""
    got = {f: means[f] / means[FRAMES[0]] for f in FRAMES}
    report[what] = {"means": means, "ratios": got}
    print("%s: means %s, ratios %s" % (what, means, got))
    for f in FRAMES:
        want = POWER[f] / POWER[FRAMES[0]]
        if not (means[FRAMES[0]] > 0 and abs(got[f] / want - 1.0) <= 0.02):
            problem("%s: frame %d's mean is %.4g x frame %d's, the power %.4g x" % (what, f, got[f], FRAMES[0], want))


def artist_material_kept(when, users):
    """The artist's material is there, its named node, its users."""
    mat = bpy.data.materials.get(ARTIST)
    if mat is None or mat.node_tree is None or mat.node_tree.nodes.get(ARTIST_NODE) is None:
        problem("%s: the artist's material or its node '%s' is gone (%s)" % (when, ARTIST_NODE, mat))
        return
    spot = bpy.data.objects.get("spot")
    slots = [s.material for s in spot.material_slots] if spot else []
    if mat.users != users or slots[:1] != [mat]:
        problem("%s: %s has %d users (expected %d), spot's slots %s" % (when, ARTIST, mat.users, users,
                                                                        [m and m.name for m in slots]))


if MODE == "reopen":
    if "ohm_blender" in bpy.context.preferences.addons:
        problem("the add-on is enabled: the renders should show what the file alone renders")
    artist_material_kept("after save and reopen", 2)
    means = {f: exr_mean(os.path.join(OUT, "frame_%04d.exr" % f)) for f in FRAMES}
    ratios_checked("reopened_command_line_renders", means)
    json.dump(report, open(REPORT, "w"), indent=1)
    if report["problems"]:
        raise SystemExit("blender_material reopen: %d problem(s)" % len(report["problems"]))
    print("blender_material reopen: ok")
    raise SystemExit(0)

install_addon(ZIP)
from ohm_blender import bridge, operators, session  # noqa: E402  (installed just now)

sc, obj, lamp = spot_with_lamp(MESH)
lamp_data = lamp.data
lamp.location = (110.0, 30.0, 0.0)
obj.ohm.preset, obj.ohm.dim, obj.ohm.solver = "marble", DIM, "direct"
obj.ohm.directory = os.path.join(OUT, "ohm", "")

# the artist's material: a node tree with a named node, on spot and on a
# second object, under the light
mat = bpy.data.materials.new(ARTIST)
mat.use_nodes = True
skin = mat.node_tree.nodes["Principled BSDF"]
skin.name = ARTIST_NODE
skin.inputs["Base Color"].default_value = (0.8, 0.5, 0.4, 1.0)
obj.data.materials.append(mat)
other = bpy.data.objects.new("other", bpy.data.meshes.new("other"))
other.data.from_pydata([(x, y, 0.0) for x in (-20, 20) for y in (-20, 20)], [], [(0, 2, 3, 1)])
other.data.materials.append(mat)
other.location = (110.0, 30.0, -100.0)  # under the light, out of spot's view
sc.collection.objects.link(other)

# Cycles, small and linear: 32x32 EXR, a black world, an orthographic camera from -y
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
sc.collection.objects.link(cam)
cam.data.type, cam.data.ortho_scale, cam.data.clip_end = "ORTHO", 70.0, 1000.0
sc.camera = cam
small_cycles(sc, 32, 4, "OPEN_EXR")
sc.render.image_settings.color_depth = "32"


def aim(target):
    """The camera on spot (at the origin) or on the other object (from above)."""
    if target == "other":
        cam.location, cam.rotation_euler = (110.0, 30.0, 400.0), (0.0, 0.0, 0.0)
    else:
        cam.location, cam.rotation_euler = (0.0, -200.0, 0.0), (np.pi / 2, 0.0, 0.0)


def render(name, samples=4):
    """A render's mean; the artist's shader, lit by the light, needs more
    samples than ohm's emission to compare within 1%."""
    path = os.path.join(OUT, name + ".exr")
    sc.render.filepath = path
    sc.cycles.samples = samples
    bpy.ops.render.render(write_still=True)
    return exr_mean(path)


def status():
    s = session.get(bpy.data.objects["spot"])
    return s.status if s else "(no session)"


# --- Solve: the material kept, the other object as before; Ctrl-Z ------------------
aim("other")
obj.hide_render = True
other_before = render("other_before", ARTIST_SAMPLES)
obj.hide_render = False
aim("spot")
artist_before = render("artist_before", ARTIST_SAMPLES)
bpy.ops.ed.undo_push(message="before Solve")
before = state()
# (from a script an operator pushes no undo step unless asked, as the button does)
if bpy.ops.ohm.solve("EXEC_DEFAULT", True) != {"FINISHED"}:
    raise SystemExit("ohm.solve did not finish: " + status())
artist_material_kept("after Solve", 2)
solved = render("solved")
aim("other")
obj.hide_render = True
other_after = render("other_after", ARTIST_SAMPLES)
obj.hide_render = False
aim("spot")
report["solve_renders"] = {"artist_before": artist_before, "solved": solved, "other_before": other_before,
                           "other_after": other_after}
if abs(other_after / other_before - 1.0) > 0.01:
    problem("the other object sharing the material rendered %.4g, %.4g before Solve" % (other_after, other_before))
if not solved > 0 or abs(solved / artist_before - 1.0) < 0.05:
    problem("spot's render did not change with Solve: %.4g, %.4g before" % (solved, artist_before))
bpy.ops.ed.undo()
# (an undo makes every datablock anew)
sc, obj, cam, lamp = bpy.context.scene, bpy.data.objects["spot"], bpy.data.objects["camera"], bpy.data.objects["lamp"]
lamp_data = lamp.data
report["undo_differences"] = differences(before, state())
if report["undo_differences"]:
    problem("Ctrl-Z after Solve: %s" % report["undo_differences"])

# --- Solve again; Show result off and on; Remove ohm result ---------------------
bpy.context.view_layer.objects.active = obj
if bpy.ops.ohm.solve() != {"FINISHED"}:
    raise SystemExit("ohm.solve (after undo) did not finish: " + status())
obj.ohm.show_result = False
hidden = render("hidden", ARTIST_SAMPLES)
obj.ohm.show_result = True
shown = render("shown")
report["show_result_renders"] = {"off": hidden, "on": shown}
if abs(hidden / artist_before - 1.0) > 0.01 or abs(shown / solved - 1.0) > 0.01:
    problem("Show result off rendered %.4g (the artist's %.4g), on %.4g (Solve's %.4g)" % (
        hidden, artist_before, shown, solved))
if bpy.ops.ohm.remove() != {"FINISHED"}:
    problem("Remove ohm result did not run")
report["remove_differences"] = differences(before, state())
if report["remove_differences"]:
    problem("Remove ohm result left: %s" % report["remove_differences"])

# --- Live, then a 20-frame bake with a volume object -------------------------
if bpy.ops.ohm.solve() != {"FINISHED"}:
    raise SystemExit("ohm.solve (before Live) did not finish: " + status())
lamp.location = (100.0, 30.0, 40.0)
bpy.context.view_layer.update()
if operators.live_step(bpy.context, obj) != "relight":
    problem("Live relight did not relight")
artist_material_kept("after Live", 2)
lamp.location = (110.0, 30.0, 0.0)
for f, p in POWER.items():
    lamp_data.energy = 2.0e4 * p
    lamp_data.keyframe_insert("energy", frame=f)
sc.frame_start, sc.frame_end = 1, 20
sc.frame_set(5)
obj.ohm.make_volume = True
progress, step = [], operators._BakeRun.step


def step_noted(run, context):  # the status the modal bake shows, before each frame and after the last
    progress.append(run.progress())
    step(run, context)
    if run.done():
        progress.append(run.progress())


operators._BakeRun.step = step_noted
if bpy.ops.ohm.bake() != {"FINISHED"}:
    raise SystemExit("ohm.bake did not finish: " + status())
operators._BakeRun.step = step
report["bake_progress"] = [progress[0], progress[-1]]
counted = [int(t.split("(")[1].split(" of ")[0]) for t in progress]
if counted != list(range(1, 21)) + [20] or any(" of 20;" not in t for t in progress):
    problem("the bake's status counted %s" % progress)
artist_material_kept("after Bake", 2)
if sc.frame_current != 5:
    problem("the bake left frame %d shown, not 5" % sc.frame_current)
# renders of frames 1, 10, 20, the test wiring nothing: the object alone, the volume alone
vol = bpy.data.objects.get(bridge.volume_name(obj))
if vol is None or not vol.data.is_sequence:
    problem("a bake with Volume object added %s" % (vol and (vol.name, vol.data.is_sequence)))
else:
    vol.hide_render = True
means = {}
for f in FRAMES:
    sc.frame_set(f)
    means[f] = render("surface_%04d" % f)
ratios_checked("surface_renders", means)
# CONTROL: ohm's frames modifier off, frames 1 and 10 render alike (the
# attribute as last written), so the check above can fail
frames_modifier = obj.modifiers.get(bridge.FRAMES_MODIFIER)
frames_modifier.show_render = False
control = {}
for f in FRAMES[:2]:
    sc.frame_set(f)
    control[f] = render("control_%04d" % f)
frames_modifier.show_render = True
report["control_without_frames_modifier"] = control
if abs(control[FRAMES[1]] / control[FRAMES[0]] - 1.0) > 0.001:
    problem("without the frames modifier frames 1 and 10 rendered %s" % control)
if vol is not None:
    vol.hide_render, obj.hide_render = False, True
    means = {}
    for f in FRAMES:
        sc.frame_set(f)
        means[f] = render("volume_%04d" % f)
    ratios_checked("volume_renders", means)
    vol.hide_render, obj.hide_render = True, False
sc.frame_set(1)
sc.render.filepath = os.path.join(OUT, "frame_####")
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(OUT, "material.blend"))

# --- a bake of frames 21-24 where nothing changes after the first (the
# power holds at its last key): one solve; frames 22-24 are links to frame
# 21's file, so Blender's sequence volume (which drops gaps) has every frame,
# and frame 23 renders as frame 21 does
sc.frame_start, sc.frame_end = 21, 24
if bpy.ops.ohm.bake() != {"FINISHED"}:
    raise SystemExit("ohm.bake (21-24) did not finish: " + status())
directory = operators.output_directory(obj)
files = {f: os.path.join(directory, "spot_%04d.vdb" % f) for f in range(21, 25)}
inodes = {f: os.stat(p).st_ino if os.path.exists(p) else None for f, p in files.items()}
vol = bpy.data.objects.get(bridge.volume_name(obj))
report["gap_bake"] = {"inodes_same_as_21": [inodes[f] == inodes[21] for f in range(21, 25)],
                      "volume": vol and [vol.data.frame_start, vol.data.frame_duration, vol.data.frame_offset]}
if None in inodes.values() or len(set(inodes.values())) != 1 or report["gap_bake"]["volume"] != [21, 4, 20]:
    problem("a bake of 21-24 with one solve left files %s and a volume %s" % (inodes, report["gap_bake"]["volume"]))
else:
    vol.hide_render, obj.hide_render = False, True
    means = {}
    for f in (21, 23):
        sc.frame_set(f)
        means[f] = render("gap_volume_%04d" % f)
    report["gap_bake"]["volume_means"] = means
    if not means[21] > 0 or abs(means[23] / means[21] - 1.0) > 1e-3:
        problem("the volume rendered frames 21 and 23 as %s" % means)

json.dump(report, open(REPORT, "w"), indent=1)
if report["problems"]:
    raise SystemExit("blender_material: %d problem(s)" % len(report["problems"]))
print("blender_material material: ok")
