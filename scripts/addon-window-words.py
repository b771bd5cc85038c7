"""addon-window-words.py — what an artist reads and sees in a real window
(run by `scripts/addon-window.sh build words` under Xvfb): Blender's default scene,
a new Suzanne at the default Scale, the Outliner turned into the Info
editor.  From the panel's buttons (the operators invoked as a click does):

  1. the Light inside Suzanne, Solve: the background job fails, and its
     ERROR report reaches the status bar and the Info editor;
  2. the Light behind the head, Solve: Suzanne's ears glow;
  3. Live relight: the light's power at 0.1x, then red, then blue;
  4. an F12 Cycles render of the result.

Saves window screenshots and the render as OUT/*.png and prints one line
per figure (WORDS ...), then quits.

  blender -P scripts/addon-window-words.py -- OUT"""
import os
import sys
import time

import bpy
import numpy as np

from ohm_blender import session

OUT = sys.argv[sys.argv.index("--") + 1]
os.makedirs(OUT, exist_ok=True)
for o in list(bpy.data.objects):
    if o.type == "MESH":
        bpy.data.objects.remove(o)
light = bpy.data.objects["Light"]
bpy.ops.mesh.primitive_monkey_add()
obj = bpy.context.active_object
state = {"phase": "start"}


def area(kind):
    for w in bpy.context.window_manager.windows:
        for a in w.screen.areas:
            if a.type == kind:
                return w, a
    return None, None


def run(op, kind="PROPERTIES"):
    w, a = area(kind)
    with bpy.context.temp_override(window=w, area=a, region=a.regions[-1]):
        return op()


def screenshot(name):
    path = os.path.join(OUT, name + ".png")
    w, a = area("VIEW_3D")
    with bpy.context.temp_override(window=w, area=a):
        bpy.ops.screen.screenshot(filepath=path)
    print("WORDS screenshot %s" % path)


def panel_steps(name):
    """The 3D view's area as a Properties editor on the Object tab,
    scrolled to ohm's panel (the last), for a screenshot; then back.  One
    step per timer tick: the new editor must draw before its tabs exist."""
    w, a = area("VIEW_3D")
    a.type = "PROPERTIES"
    yield
    a.spaces[0].context = "OBJECT"
    yield
    region = next(r for r in a.regions if r.type == "WINDOW")
    for _ in range(8):  # each scroll is clamped to what has been drawn
        with bpy.context.temp_override(window=w, area=a, region=region):
            bpy.ops.view2d.scroll_down(page=True)
        yield
    with bpy.context.temp_override(window=w, area=a):
        bpy.ops.screen.screenshot(filepath=os.path.join(OUT, name + ".png"))
    print("WORDS screenshot %s" % os.path.join(OUT, name + ".png"))
    a.type = "VIEW_3D"


def mean_colour():
    me = obj.data
    c = np.empty(4 * len(me.vertices), dtype=np.float32)
    me.attributes[obj.ohm.attribute].data.foreach_get("color", c)
    return c.reshape(-1, 4)[:, :3].mean(axis=0)


def set_up_window():
    for w in bpy.context.window_manager.windows:
        for a in w.screen.areas:
            if a.type == "PROPERTIES":
                a.spaces[0].context = "OBJECT"
            elif a.type == "OUTLINER":  # reports show in the Info editor
                a.type = "INFO"
            elif a.type == "VIEW_3D":
                a.spaces[0].region_3d.view_rotation = (0.7071, 0.7071, 0.0, 0.0)  # from the front (-y)
                a.spaces[0].region_3d.view_perspective = "ORTHO"
                a.spaces[0].region_3d.view_distance = 4.0
                a.spaces[0].region_3d.view_location = (0.0, 0.0, 0.0)


def tick():
    s = session.get(obj)
    phase, now = state["phase"], time.perf_counter()
    if state.get("steps") is not None:  # a panel screenshot under way
        if next(state["steps"], "done") == "done":
            state["steps"] = None
        return 0.3
    if phase == "start":
        set_up_window()
        light.location = (0.0, 0.0, 0.0)
        run(lambda: bpy.ops.ohm.solve("INVOKE_DEFAULT"))
        state.update(phase="inside", t0=now)
    elif phase == "inside" and s is not None and s.job is None and now - state["t0"] > 0.5:
        print("WORDS light inside: status %r; notes %s" % (s.status, [(n.level, n.text) for n in s.notes]))
        state.update(phase="shot inside", t0=now)
    elif phase == "shot inside" and now - state["t0"] > 1.0:  # the redraw shows the reports
        screenshot("1-light-inside")
        state.update(phase="panel inside", steps=panel_steps("1b-panel-light-inside"))
    elif phase == "panel inside":
        light.location, light.data.energy = (0.0, 4.0, 0.3), 1000.0
        run(lambda: bpy.ops.ohm.solve("INVOKE_DEFAULT"))
        state.update(phase="behind", t0=now)
    elif phase == "behind" and s.job is None and now - state["t0"] > 0.5:
        print("WORDS light behind: status %r; notes %s" % (s.status, [(n.level, n.text) for n in s.notes]))
        state.update(phase="shot behind", t0=now)
    elif phase == "shot behind" and now - state["t0"] > 1.0:
        screenshot("2-light-behind")
        state.update(phase="panel behind", steps=panel_steps("2b-panel-light-behind"))
    elif phase == "panel behind":
        light.location = (3.0, -3.0, 1.0)
        run(lambda: bpy.ops.ohm.live("INVOKE_DEFAULT"))
        state.update(phase="live", t0=now, relights=s.relights)
    elif phase == "live" and s.relights > state["relights"] and s.job is None:
        state.update(phase="live full", t0=now, full=mean_colour(), relights=s.relights)
        light.data.energy = 100.0
    elif phase == "live full" and s.relights > state["relights"] and s.job is None:
        tenth = mean_colour()
        print("WORDS live: power 1000 W -> 100 W: mean colour %s -> %s, ratio %.4f" % (
            state["full"], tenth, tenth.mean() / state["full"].mean()))
        screenshot("3-live-tenth")
        light.data.energy, light.data.color = 1000.0, (1.0, 0.0, 0.0)
        state.update(phase="live red", relights=s.relights)
    elif phase == "live red" and s.relights > state["relights"] and s.job is None:
        state.update(phase="live blue", red=mean_colour(), relights=s.relights)
        screenshot("4-live-red")
        light.data.color = (0.0, 0.0, 1.0)
    elif phase == "live blue" and s.relights > state["relights"] and s.job is None:
        blue = mean_colour()
        print("WORDS live: red light then blue: red channel %.4g -> %.4g" % (state["red"][0], blue[0]))
        screenshot("5-live-blue")
        light.data.color, light.location = (1.0, 1.0, 1.0), (0.0, 4.0, 0.3)
        state.update(phase="live back", relights=s.relights)
    elif phase == "live back" and s.relights > state["relights"] and s.job is None:
        sc = bpy.context.scene
        cam = bpy.data.objects["Camera"]
        cam.location, cam.rotation_euler = (0.0, -10.0, 0.0), (np.pi / 2, 0.0, 0.0)
        cam.data.type, cam.data.ortho_scale = "ORTHO", 3.2
        sc.render.engine, sc.cycles.samples, sc.cycles.use_denoising = "CYCLES", 16, False
        sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 320, 320, 100
        sc.world.use_nodes, sc.world.color = False, (0.0, 0.0, 0.0)
        sc.render.filepath = os.path.join(OUT, "6-cycles-f12.png")
        bpy.ops.render.render(write_still=True)
        print("WORDS render %s" % sc.render.filepath)
        bpy.ops.wm.quit_blender()
        return None
    elif now - state.get("t0", now) > 120:
        print("WORDS stuck in %s: %s" % (phase, s.status if s else None))
        bpy.ops.wm.quit_blender()
        return None
    return 0.05


bpy.app.timers.register(tick, first_interval=2.0)
