"""addon-window.py — the Blender add-on in a real window (run by
scripts/addon-window.sh under Xvfb, not headless): what an artist feels.

  blender -P scripts/addon-window.py -- solve DIM   # Solve from the button, then a second one cancelled,
                                                    # then a third stopped by Esc while it voxelizes
  blender -P scripts/addon-window.py -- live DIM    # Live relight with the light moved every tick
  blender -P scripts/addon-window.py -- material 0  # the artist's material: Solve, Ctrl-Z, Bake, renders, Remove

A 20 ms bpy.app.timers timer records when Blender's main thread runs; the
add-on's own main-thread steps are timed by wrapping them.  Prints one line
per figure (docs/blender.md quotes them) and quits.  Spot, 50 mm, 1 unit =
1 mm; skin1 for solve, marble for live; Solver: Direct unless SOLVER= says
otherwise; NO3D=1 turns the 3D views into text editors (live: the rate
without Blender's viewport redraw).  material: the default scene's Cube
replaced by Suzanne with a Subdivision modifier and the artist's material
"MyHandmadeSkin" (a node named "my skin"), the panel's defaults, the
default light; clicks through the operators as the buttons run them (Solve,
Live relight, Bake, Remove), Ctrl-Z and Esc as real key presses (xdotool); screenshots of the window (ImageMagick's
import) and Cycles renders (.png to look at, .exr measured) in
OHM_WINDOW_OUT (default /tmp/ohm-window)."""
import math
import os
import subprocess
import sys
import time

import bpy
import numpy as np

from ohm_blender import operators, session

MODE, DIM = sys.argv[sys.argv.index("--") + 1], int(sys.argv[sys.argv.index("--") + 2])
ESC_DIM = int(os.environ.get("ESC_DIM", "112"))  # Spot at 50 mm: 198 991 cells
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests"))
from blender_scene import differences, spot_with_lamp  # noqa: E402
from blender_scene import state as blend_state  # noqa: E402
marks = []  # (what, start, seconds) of the add-on's main-thread steps


def timed(owner, name):
    f = getattr(owner, name)

    def wrapper(*a, **k):
        t0 = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            marks.append((name, t0, time.perf_counter() - t0))
    setattr(owner, name, wrapper)


for name in ("gather", "finish", "relight_finish"):
    timed(session.Session, name)
timed(operators, "_after_setup")


def build_scene():
    sc, obj, lamp = spot_with_lamp(os.path.join(ROOT, "samples", "spot.obj"))
    lamp.location = (100, 40, 40) if MODE == "solve" else (110, 0, 0)
    obj.ohm.preset = "skin1" if MODE == "solve" else "marble"
    obj.ohm.dim = DIM
    obj.ohm.solver = os.environ.get("SOLVER", "direct")
    return obj, lamp


def artist_scene():
    """The default scene with Suzanne (a Subdivision modifier) in the Cube's
    place, wearing the artist's own material; the default light."""
    import bmesh
    sc = bpy.context.scene
    cube = bpy.data.objects.get("Cube")
    if cube is not None:
        bpy.data.objects.remove(cube)
    me = bpy.data.meshes.new("Suzanne")
    bm = bmesh.new()
    bmesh.ops.create_monkey(bm)
    bm.to_mesh(me)
    bm.free()
    obj = bpy.data.objects.new("Suzanne", me)
    sc.collection.objects.link(obj)
    obj.modifiers.new("Subdivision", "SUBSURF").levels = 1
    mat = bpy.data.materials.new("MyHandmadeSkin")
    mat.use_nodes = True
    mat.node_tree.nodes["Principled BSDF"].name = "my skin"
    me.materials.append(mat)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    return obj, bpy.data.objects["Light"]


def areas(kind):
    for w in bpy.context.window_manager.windows:
        for a in w.screen.areas:
            if a.type == kind:
                yield w, a


def run(op, kind="VIEW_3D"):
    w, a = next(areas(kind))
    with bpy.context.temp_override(window=w, area=a):
        return op()


obj, lamp = artist_scene() if MODE == "material" else build_scene()
for w, a in areas("PROPERTIES"):
    for sp in a.spaces:
        if sp.type == "PROPERTIES":
            sp.context = "OBJECT"
for w, a in list(areas("VIEW_3D")):
    if os.environ.get("NO3D") == "1":
        a.type = "TEXT_EDITOR"
    else:
        for sp in a.spaces:
            if sp.type == "VIEW_3D" and MODE == "material":
                sp.region_3d.view_distance = 7.0
            elif sp.type == "VIEW_3D":
                sp.region_3d.view_distance, sp.clip_end = 150, 1000
ticks = []  # (time, phase)
state = {"phase": "start", "k": 0}


def largest_gaps(phase, count=3):
    t = [x for x, p in ticks if p == phase]
    return sorted(np.diff(t), reverse=True)[:count] if len(t) > 1 else []


def solve_tick(now, s, phase):
    if phase == "start":
        run(lambda: bpy.ops.ohm.solve("INVOKE_DEFAULT"))
        state.update(phase="solving", t0=now)
    elif phase == "solving" and s.job is None and now - state["t0"] > 0.5:
        print("SOLVE: %s, in %.2f s in the window" % (s.status, now - state["t0"]))
        state.update(phase="redraw", t1=now)
    elif phase == "redraw" and now - state["t1"] > 0.5:  # Blender's redraw alone, nothing solving
        for w, a in list(areas("VIEW_3D")) + list(areas("PROPERTIES")):
            a.tag_redraw()
        state.update(phase="redrawn", t1=now)
        return 0.001
    elif phase == "redrawn":
        print("REDRAW of the 3D view and Properties, nothing solving: %.3f s" % (now - state["t1"]))
        obj.ohm.dim = DIM + 8  # a new setup, to cancel
        run(lambda: bpy.ops.ohm.solve("INVOKE_DEFAULT"))
        state.update(phase="second", t0=now)
    elif phase == "second" and s.progress[0] == "solve: factorize" and s.progress[1] > 0.1:
        run(lambda: bpy.ops.ohm.cancel(), "PROPERTIES")
        state.update(phase="cancelling", tc=now, at=s.progress[1])
    elif phase == "cancelling" and s.job is None:
        print("CANCEL at %.0f%% of the factorization: stopped after %.3f s (%s)" % (
            100 * state["at"], now - state["tc"], s.status))
        print("GAPS during the solve (s): %s" % ["%.3f" % g for g in largest_gaps("solving")])
        main = [d for _, _, d in marks]
        print("MAIN THREAD: the add-on's longest step %.1f ms (%s)" % (
            1e3 * max(main), max(marks, key=lambda m: m[2])[0]))
        obj.ohm.dim = ESC_DIM  # a new setup, stopped by Esc while it voxelizes
        run(lambda: bpy.ops.ohm.solve("INVOKE_DEFAULT"))
        state.update(phase="third", t0=now)
    elif phase == "third" and s.progress[0].startswith("voxelize") and s.progress[1] > 0.2:
        # a real key press, as an artist's (xdotool, through the X server)
        subprocess.Popen(["xdotool", "mousemove", "400", "300", "key", "Escape"])
        state.update(phase="escaping", tc=now, at=s.progress)
    elif phase == "escaping" and s.job is None:
        print("ESC during %s at %.0f%% (dim %d): stopped after %.3f s (%s)" % (
            state["at"][0], 100 * state["at"][1], ESC_DIM, now - state["tc"], s.status))
        return None
    elif phase == "escaping" and now - state["tc"] > 30:
        print("ESC during %s: not stopped after 30 s" % state["at"][0])
        return None
    return 0.02


def live_tick(now, s, phase):
    if phase == "start":
        run(lambda: bpy.ops.ohm.live("INVOKE_DEFAULT"), "PROPERTIES")
        state.update(phase="setup", t0=now)
    elif phase == "setup" and s is not None and s.scene is not None and s.job is None:
        state.update(phase="moving", t0=now, r0=s.relights)
    elif phase == "moving":
        state["k"] += 1
        a = 0.15 * state["k"]
        lamp.location = (110 * math.cos(a), 110 * math.sin(a), 20)
        if now - state["t0"] > 6.0:
            n = s.relights - state["r0"]
            print("LIVE (%s): %d cells, %.1f updates/s; last update (ms) %s" % (
                "no 3D view" if os.environ.get("NO3D") == "1" else "with the 3D view", s.result["unknowns"],
                n / (now - state["t0"]), {k: round(1e3 * v, 1) for k, v in s.last.items()}))
            return None
        return 1.0 / 60
    return 0.02


OUTDIR = os.environ.get("OHM_WINDOW_OUT", "/tmp/ohm-window")


def shot(name):
    """The X screen as it shows now."""
    path = os.path.join(OUTDIR, name + ".png")
    subprocess.run(["import", "-window", "root", path], check=False)
    print("SHOT: " + path)


def key(keys):
    """A real key press through the X server, the pointer over the 3D view."""
    w, a = next(areas("VIEW_3D"))
    x, y = a.x + a.width // 2, w.height - (a.y + a.height // 2)
    subprocess.run(["xdotool", "mousemove", str(x), str(y), "key", keys], check=False)


def shading(kind):
    for w, a in areas("VIEW_3D"):
        for sp in a.spaces:
            if sp.type == "VIEW_3D":
                sp.shading.type = kind


def kept(when):
    """The artist's material: there, its node, its user, in Suzanne's slot."""
    mat = bpy.data.materials.get("MyHandmadeSkin")
    suzanne = bpy.data.objects["Suzanne"]
    ok = mat is not None and mat.node_tree.nodes.get("my skin") is not None and mat.users == 1 and \
        suzanne.material_slots[0].material == mat
    print("MATERIAL KEPT %s: %s (users %s, Suzanne's slots %s)" % (
        when, ok, mat and mat.users, [s.material and s.material.name for s in suzanne.material_slots]))


def f12(name):
    """A Cycles render, as F12 makes it: .exr (linear, measured) and .png; its mean."""
    sc = bpy.context.scene
    sc.render.filepath = os.path.join(OUTDIR, name + ".exr")
    bpy.ops.render.render(write_still=True)
    bpy.data.images["Render Result"].save_render(os.path.join(OUTDIR, name + ".png"))
    img = bpy.data.images.load(sc.render.filepath)
    mean = float(np.array(img.pixels[:]).reshape(-1, 4)[:, :3].mean())
    bpy.data.images.remove(img)
    return mean


def material_steps():
    """The artist's session, step by step; each yield is the seconds to the next."""
    os.makedirs(OUTDIR, exist_ok=True)
    sc = bpy.context.scene

    def waiting():  # until the running operator's job ends
        t0 = time.perf_counter()
        while True:
            s = session.get(bpy.data.objects["Suzanne"])
            if s is not None and s.job is None and time.perf_counter() - t0 > 0.5:
                return s
            yield 0.05
    shading("MATERIAL")
    w, a = next(areas("VIEW_3D"))
    with bpy.context.temp_override(window=w, area=a):
        bpy.ops.ed.undo_push(message="the artist's scene")  # as the artist's own edits push theirs
    before = blend_state()
    yield 2.0
    shot("0-artist-material-preview")
    run(lambda: bpy.ops.ohm.solve("INVOKE_DEFAULT"))
    s = yield from waiting()
    print("MATERIAL SOLVE: " + s.status)
    kept("after Solve")
    yield 20.0  # EEVEE compiles the material's shader anew (8 s was not always enough on a busy machine)
    shot("1-solved-material-preview")
    w, a = next(areas("VIEW_3D"))  # the material's nodes, ohm's group among them
    a.type = "NODE_EDITOR"
    a.spaces[0].tree_type = "ShaderNodeTree"
    yield 0.5
    with bpy.context.temp_override(window=w, area=a, region=a.regions[-1]):
        bpy.ops.node.view_all()
    yield 1.0
    shot("1-solved-node-tree")
    a.type = "VIEW_3D"
    yield 0.5
    key("ctrl+z")
    yield 2.0
    print("MATERIAL CTRL-Z after Solve: differences from before %s" % differences(before, blend_state()))
    shot("2-ctrl-z")
    sc, obj = bpy.context.scene, bpy.data.objects["Suzanne"]  # (an undo makes every datablock anew)
    bpy.context.view_layer.objects.active = obj
    run(lambda: bpy.ops.ohm.solve("INVOKE_DEFAULT"))
    s = yield from waiting()
    obj.ohm.show_result = False
    yield 2.0
    shot("3-show-result-off")
    obj.ohm.show_result = True
    # a 20-frame bake: the light's power 1 -> 0.5 -> 1, with Volume object
    light = bpy.data.objects["Light"].data
    power = {1: light.energy, 10: 0.5 * light.energy, 20: light.energy}
    for f, p in power.items():
        light.energy = p
        light.keyframe_insert("energy", frame=f)
    sc.frame_start, sc.frame_end = 1, 20
    obj.ohm.make_volume = True
    run(lambda: bpy.ops.ohm.bake("INVOKE_DEFAULT"))
    seen, t0 = [], time.perf_counter()
    while True:
        s = session.get(obj)
        if s.status.startswith("baking") and (not seen or seen[-1] != s.status):
            seen.append(s.status)
        if s.status.startswith("baked") or s.status.startswith("stopped") or time.perf_counter() - t0 > 120:
            break
        yield 0.02
    print("MATERIAL BAKE: %s; its status went %s ... %s (%d lines)" % (s.status, seen[:1], seen[-1:], len(seen)))
    kept("after Bake")
    vol = bpy.data.objects.get(obj.name + "_ohm")
    if vol is not None:  # the surface alone in the viewport
        vol.hide_viewport = True
    for f in (1, 10):
        sc.frame_set(f)
        yield 8.0
        shot("4-frame%d-material-preview" % f)
    sc.render.engine = "CYCLES"
    sc.cycles.preview_samples = 8
    shading("RENDERED")
    yield 25.0  # Cycles compiles its shaders and renders in the window, on a shared CPU
    shot("5-frame10-rendered")
    shading("MATERIAL")
    # F12 at frames 1, 10, 20 in a black world (the background would add to
    # the mean): Suzanne, then the volume object alone
    sc.world.use_nodes, sc.world.color = False, (0.0, 0.0, 0.0)
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 320, 240, 100
    sc.cycles.samples, sc.cycles.use_denoising = 16, False
    sc.render.image_settings.file_format = "OPEN_EXR"
    for what, hidden in (("surface", vol), ("volume", obj)):
        if hidden is None:
            print("MATERIAL RENDERS %s: no volume object" % what)
            continue
        hidden.hide_render = True
        means = {}
        for f in power:
            sc.frame_set(f)
            means[f] = f12("f12-%s-%04d" % (what, f))
        hidden.hide_render = False
        print("MATERIAL RENDERS %s: means %s; ratios to frame 1 %s, the power's %s" % (
            what, {f: round(m, 6) for f, m in means.items()}, {f: round(m / means[1], 4) for f, m in means.items()},
            {f: p / power[1] for f, p in power.items()}))
        yield 0.5
    # Live relight from its button, the light moved, stopped by a real Esc (after the bake:
    # an Esc that lands between two relights leaves the library's cancel pending for the next run)
    light_obj = bpy.data.objects["Light"]
    run(lambda: bpy.ops.ohm.live("INVOKE_DEFAULT"), "PROPERTIES")
    home = tuple(light_obj.location)
    for k in range(60):
        light_obj.location = (home[0], home[1] + 0.05 * k, home[2])
        yield 0.05
    key("Escape")
    yield 1.0
    light_obj.location = home
    print("MATERIAL LIVE: %s" % session.get(obj).status)
    kept("after Live")
    sc.frame_set(1)
    run(lambda: bpy.ops.ohm.remove(), "PROPERTIES")
    yield 2.0
    print("MATERIAL REMOVE: differences from before Solve %s" % differences(before, blend_state()))
    shot("6-removed")
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(OUTDIR, "window.blend"))


steps = material_steps() if MODE == "material" else None


def tick():
    now = time.perf_counter()
    if steps is not None:
        try:
            again = next(steps, None)
        except Exception:
            import traceback
            traceback.print_exc()
            print("PROBLEM: the material steps failed")
            again = None
        if again is None:
            bpy.ops.wm.quit_blender()
        return again
    s = session.get(obj)
    ticks.append((now, state["phase"]))
    again = (solve_tick if MODE == "solve" else live_tick)(now, s, state["phase"])
    if again is None:
        bpy.ops.wm.quit_blender()
    return again


bpy.app.timers.register(tick, first_interval=2.0)
