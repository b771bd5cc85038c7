"""addon-window.py — the Blender add-on in a real window (run by
scripts/addon-window.sh under Xvfb, not headless): what an artist feels.

  blender -P scripts/addon-window.py -- solve DIM   # Solve from the button, then a second one cancelled,
                                                    # then a third stopped by Esc while it voxelizes
  blender -P scripts/addon-window.py -- live DIM    # Live relight with the light moved every tick

A 20 ms bpy.app.timers timer records when Blender's main thread runs; the
add-on's own main-thread steps are timed by wrapping them.  Prints one line
per figure (docs/blender.md quotes them) and quits.  Spot, 50 mm, 1 unit =
1 mm; skin1 for solve, marble for live; Solver: Direct unless SOLVER= says
otherwise; NO3D=1 turns the 3D views into text editors (live: the rate
without Blender's viewport redraw)."""
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
from blender_scene import read_obj, scene_with_mesh  # noqa: E402
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
    verts, faces = read_obj(os.path.join(ROOT, "samples", "spot.obj"))
    verts = np.array(verts)
    verts = (verts - verts.mean(axis=0)) * (50.0 / np.ptp(verts, axis=0).max())
    sc, obj = scene_with_mesh("spot", verts, faces)
    lamp_data = bpy.data.lights.new("lamp", "POINT")
    lamp_data.energy = 2.0e4
    lamp = bpy.data.objects.new("lamp", lamp_data)
    sc.collection.objects.link(lamp)
    lamp.location = (100, 40, 40) if MODE == "solve" else (110, 0, 0)
    obj.ohm.preset = "skin1" if MODE == "solve" else "marble"
    obj.ohm.dim = DIM
    obj.ohm.solver = os.environ.get("SOLVER", "direct")
    return obj, lamp


def areas(kind):
    for w in bpy.context.window_manager.windows:
        for a in w.screen.areas:
            if a.type == kind:
                yield w, a


def run(op, kind="VIEW_3D"):
    w, a = next(areas(kind))
    with bpy.context.temp_override(window=w, area=a):
        return op()


obj, lamp = build_scene()
for w, a in areas("PROPERTIES"):
    for sp in a.spaces:
        if sp.type == "PROPERTIES":
            sp.context = "OBJECT"
for w, a in list(areas("VIEW_3D")):
    if os.environ.get("NO3D") == "1":
        a.type = "TEXT_EDITOR"
    else:
        for sp in a.spaces:
            if sp.type == "VIEW_3D":
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


def tick():
    now = time.perf_counter()
    s = session.get(obj)
    ticks.append((now, state["phase"]))
    again = (solve_tick if MODE == "solve" else live_tick)(now, s, state["phase"])
    if again is None:
        bpy.ops.wm.quit_blender()
    return again


bpy.app.timers.register(tick, first_interval=2.0)
