"""blender_addon.py — the Blender add-on, headless (tests/cli_blender_addon.sh):

  blender -b --factory-startup --python-exit-code 1 -P tests/blender_addon.py -- \
      ZIP MESH OUTDIR REPORT.json MODE [DIM] [MOVES]

MODE live: installs the add-on from its zip, builds the mesh (50 mm, 1
Blender unit = 1 mm) and a point light, runs bpy.ops.ohm.solve, checks the
colour attribute and that the side facing the light is brighter; then moves
the light around the object through Live relight's update (as its timer
calls it): the bright side follows the light, and no factorization is made
after the first solve; a change of material refactors once.  It reports
the updates per second and their parts.  Then (live): a 64x64 Cycles render
after Solve (the lit half brighter), exposure, rename, modifiers, moves; a
background solve of 2.4e5 cells cancelled (progress from inside the
factorization, the main thread ticking, nothing changed); the memory guard
(refusals, and a solve at the largest Cells Memory 5% allows staying under
it); warnings as reports; deleting the object while it solves.  MODE bake: a
light animated over 4 frames, bpy.ops.ohm.bake: 4 .vdb files, 4 per-frame
attributes, one setup; a light whose power doubles (the colours double);
a static light over 250 frames (at most one solve, one file); and Solve's
volume object, placed half a voxel back over the mesh, rendered alone in
Cycles (not black, the lit half brighter).
Any failed check raises, so Blender exits 1."""
import json
import math
import os
import re
import sys
import time

import bpy
import numpy as np

args = sys.argv[sys.argv.index("--") + 1:]
ZIP, MESH, OUT, REPORT, MODE = args[:5]
DIM = int(args[5]) if len(args) > 5 else 32
MOVES = int(args[6]) if len(args) > 6 else 24
# the background solve that is cancelled: 120^3 over the 50 mm spot is
# 2.4e5 cells, where a factorization takes seconds
BIG_DIM = 120
report = {"mode": MODE, "dim": DIM, "problems": []}
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_scene import install_addon, read_obj, scene_with_mesh, small_cycles  # noqa: E402


def problem(text):
    report["problems"].append(text)
    print("PROBLEM:", text)


install_addon(ZIP)
from ohm_blender import bridge, estimate, operators, session  # noqa: E402  (installed just now)

verts, faces = read_obj(MESH)
verts = np.array(verts)
verts = (verts - verts.mean(axis=0)) * (50.0 / np.ptp(verts, axis=0).max())
sc, obj = scene_with_mesh("spot", verts, faces)
me = obj.data
lamp_data = bpy.data.lights.new("lamp", "POINT")
lamp_data.energy = 2.0e4  # W: about 1.3 mW/mm^2 at 110 mm
lamp = bpy.data.objects.new("lamp", lamp_data)
sc.collection.objects.link(lamp)
obj.ohm.preset = "marble"
obj.ohm.dim = DIM
SOLVER = os.environ.get("OHM_ADDON_SOLVER", "direct")
if SOLVER == "auto" and obj.ohm.solver != "auto":
    problem("the panel's default solver is %s, not auto" % obj.ohm.solver)
obj.ohm.solver = SOLVER
# the panel's Device (Multigrid on an OpenCL device: PoCL's CPU in CI)
DEVICE = os.environ.get("OHM_ADDON_DEVICE", "host")
obj.ohm.device = DEVICE


def status():
    s = session.get(obj)
    return s.status if s else "(no session)"


def place_light(direction, distance=110.0):
    d = np.asarray(direction, dtype=float)
    lamp.location = tuple(d / np.linalg.norm(d) * distance)
    bpy.context.view_layer.update()


def luminance_of(name):
    c = np.empty(4 * len(me.vertices), dtype=np.float32)
    me.attributes[name].data.foreach_get("color", c)
    c = c.reshape(-1, 4)
    return 0.2126 * c[:, 0] + 0.7152 * c[:, 1] + 0.0722 * c[:, 2]


def luminance():
    return luminance_of(obj.ohm.attribute)


def facing_contrast(direction):
    """Mean brightness of the vertices on the light's side over the far side's."""
    d = np.asarray(direction, dtype=float)
    side = verts @ (d / np.linalg.norm(d))
    lum = luminance()
    near, far = lum[side > 0.3 * side.max()], lum[side < 0.3 * side.min()]
    return float(near.mean() / max(far.mean(), 1e-30))


def screenshot(path, light_dir):
    """The colour attribute as Blender's viewport shows it (Workbench,
    colour by attribute), lit from light_dir, for the README."""
    obj.ohm.preset = "skin1"
    place_light(light_dir)
    operators.live_step(bpy.context, obj)
    obj.ohm.exposure = 0.5 / float(np.percentile(session.get(obj).scene.vertex_exitance()[:, 0], 99))
    me.color_attributes.active_color = me.color_attributes[obj.ohm.attribute]
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    sc.collection.objects.link(cam)
    d = np.array([0.5, 0.25, 1.0])
    cam.location = tuple(d / np.linalg.norm(d) * 120)
    look = -np.array(cam.location)
    import mathutils
    cam.rotation_euler = mathutils.Vector(tuple(look)).to_track_quat("-Z", "Y").to_euler()
    cam.data.clip_end = 1000
    sc.camera = cam
    sc.render.engine = "BLENDER_WORKBENCH"
    sc.display.shading.light = "FLAT"
    sc.display.shading.color_type = "VERTEX"
    sc.render.resolution_x, sc.render.resolution_y = 480, 360
    sc.render.filepath = path
    bpy.ops.render.render(write_still=True)


def cycles_halves(path):
    """A 64x64 Cycles render, 8 samples, from -y (the light's +x side on the
    image's right), orthographic over the object, black world: the mean
    luminance of the right half's and of the left half's pixels."""
    cam = bpy.data.objects.get("ohm test camera")
    if cam is None:
        cam = bpy.data.objects.new("ohm test camera", bpy.data.cameras.new("ohm test camera"))
        sc.collection.objects.link(cam)
    cam.data.type, cam.data.ortho_scale, cam.data.clip_end = "ORTHO", 70.0, 1000.0
    cam.location, cam.rotation_euler = (0.0, -200.0, 0.0), (math.pi / 2, 0.0, 0.0)
    sc.camera = cam
    small_cycles(sc, 64, 8, "PNG")
    sc.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    px = np.array(img.pixels[:], dtype=np.float64).reshape(64, 64, 4)
    bpy.data.images.remove(img)
    lum = 0.2126 * px[:, :, 0] + 0.7152 * px[:, :, 1] + 0.0722 * px[:, :, 2]
    return float(lum[:, 32:].mean()), float(lum[:, :32].mean())


def rss_kib(field):
    """This process's VmRSS or VmHWM (its peak since clear_refs), KiB."""
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith(field + ":"))


def guarded_solve():
    """At the lowest Memory the panel allows, Solve at the largest Cells
    the refusal names: the process's memory grows by less than the guard."""
    obj.ohm.max_memory_fraction = 0.05
    obj.ohm.dim = 1024
    try:
        bpy.ops.ohm.solve()
    except RuntimeError:
        pass
    m = re.search(r"the largest Cells that fits is (\d+)", status())
    if not m:
        problem("no largest Cells named at Memory 5%%: %s" % status())
        return
    obj.ohm.dim = int(m.group(1))
    budget = bridge.memory_budget_mb(obj.ohm.max_memory_fraction)[0] * 2 ** 20
    with open("/proc/self/clear_refs", "w") as f:  # VmHWM from here
        f.write("5")
    before = rss_kib("VmRSS")
    ok = bpy.ops.ohm.solve() == {"FINISHED"}
    grew = (rss_kib("VmHWM") - before) * 1024.0
    report["guarded_solve"] = {"cells_setting": obj.ohm.dim, "cells": int(session.get(obj).result["unknowns"]),
                               "guard_bytes": budget, "grew_bytes": grew}
    if not ok or not grew <= budget:
        problem("Cells %d at Memory 5%%: %s, the process grew %.0f MB against a guard of %.0f MB" % (
            obj.ohm.dim, status(), grew / 2 ** 20, budget / 2 ** 20))
    obj.ohm.max_memory_fraction, obj.ohm.dim = 0.5, DIM


if MODE == "live":
    place_light((1, 0.3, 0))
    if bpy.ops.ohm.solve() != {"FINISHED"}:
        raise SystemExit("ohm.solve did not finish: " + status())
    if obj.ohm.attribute not in me.attributes:
        problem("no colour attribute %s after Solve" % obj.ohm.attribute)
    s = session.get(obj)
    report["cells"] = int(s.result["unknowns"])
    report["factorizations_after_solve"] = session.get(obj).factorizations
    report["solver"] = s.solver
    if (DEVICE != "host") != s.solver.startswith("mg on "):
        problem("Device %s with Solver %s solved with %r" % (DEVICE, SOLVER, s.solver))
    if SOLVER == "auto" and (s.solver != "direct" or "Auto: direct" not in s.solver_note):
        problem("Auto at %d cells solved with %s (%s), expected the factor" % (report["cells"], s.solver,
                                                                           s.solver_note))
    report["contrast_after_solve"] = facing_contrast((1, 0.3, 0))
    if not report["contrast_after_solve"] > 2:
        problem("lit side only %.3g x the far side after Solve" % report["contrast_after_solve"])
    if SOLVER == "direct":  # what the artist renders, without wiring anything: the lit (right) half brighter
        place_light((1, 0, 0))
        operators.live_step(bpy.context, obj)
        right, left = report["cycles_right_left"] = cycles_halves(os.path.join(OUT, "cycles.png"))
        if not (right > 1.5 * left and right > 0.02):
            problem("a Cycles render after Solve: lit half %.4g, far half %.4g" % (right, left))
        place_light((1, 0.3, 0))
        operators.live_step(bpy.context, obj)
    # the light around the object: the bright side follows
    follows = []
    for d in [(-1, 0.3, 0), (0, 0.3, 1), (0, 0.3, -1), (1, 0.3, 0)]:
        place_light(d)
        what = operators.live_step(bpy.context, obj)
        if what != "relight":
            problem("moving the light gave %r, expected a relight" % what)
        follows.append(facing_contrast(d))
    report["contrast_following"] = follows
    if not min(follows) > 2:
        problem("the bright side did not follow the light: contrasts %s" % follows)
    # many small moves, as a user dragging the light: updates per second
    parts = {}
    t0 = time.perf_counter()
    for k in range(MOVES):
        a = 2 * math.pi * k / MOVES
        place_light((math.cos(a), 0.3, math.sin(a)))
        operators.live_step(bpy.context, obj)
        for key, v in s.last.items():
            parts[key] = parts.get(key, 0.0) + v
    elapsed = time.perf_counter() - t0
    report["updates_per_second"] = MOVES / elapsed
    report["update_parts_ms"] = {k: 1e3 * v / MOVES for k, v in parts.items()}
    report["factorizations_after_live"] = session.get(obj).factorizations
    if session.get(obj).factorizations != report["factorizations_after_solve"] or s.setups != 1:
        problem("live relight factored again: %d factorizations, %d setups" % (session.get(obj).factorizations, s.setups))
    # a change of material refactors once, then relights again
    obj.ohm.preset = "skin1"
    what = operators.live_step(bpy.context, obj)
    what2 = operators.live_step(bpy.context, obj)
    if what != "setup" or what2 is not None or s.setups != 2:
        problem("a new material gave %r then %r (%d setups), expected one setup" % (what, what2, s.setups))
    # what Solve shows without wiring, on an object without a material: ohm's
    # own material, its node group emitting the attribute; the attribute
    # active for the viewport
    mat = obj.material_slots[0].material if obj.material_slots else None
    groups = [n.node_tree for n in mat.node_tree.nodes if bridge._is_result_node(n)] if mat and mat.use_nodes else []
    attr_nodes = [n for n in groups[0].nodes if n.type == "ATTRIBUTE" and n.attribute_type == "GEOMETRY"] if groups else []
    if not attr_nodes or attr_nodes[0].attribute_name != obj.ohm.attribute or \
            not any(n.type == "EMISSION" for n in groups[0].nodes) or not mat.get(bridge.OWN_MATERIAL):
        problem("Solve left no material emitting %s: %s" % (obj.ohm.attribute, mat))
    if me.color_attributes.active_color is None or me.color_attributes.active_color.name != obj.ohm.attribute:
        problem("the colour attribute is not the active one")
    # a new exposure recolours at once, without a solve
    before = luminance().copy()
    runs = (s.setups, s.relights)
    obj.ohm.exposure = 2.0 * s.exposure
    ratio = float(np.median(luminance()[before > 0] / before[before > 0]))
    report["exposure_doubled_ratio"] = ratio
    if abs(ratio - 2.0) > 1e-3 or (s.setups, s.relights) != runs:
        problem("doubling the exposure scaled the colours by %.4g with %s runs" % (ratio, (s.setups, s.relights)))
    obj.ohm.exposure = 0.0
    # a rename keeps the session (and its solver)
    obj.name = "spot renamed"
    if session.get(obj) is not s or operators.live_step(bpy.context, obj) is not None:
        problem("a rename lost the session")
    obj.name = "spot"
    # a modifier changes the geometry Blender shows: a new setup on it, the
    # colours still on the mesh's own vertices
    mod = obj.modifiers.new("sub", "SUBSURF")
    mod.levels = 1
    what = operators.live_step(bpy.context, obj)
    cells_sub = int(s.result["unknowns"])
    report["cells_with_subdivision"] = cells_sub
    if what != "setup" or s.to_original is None or len(luminance()) != len(me.vertices):
        problem("a Subdivision modifier gave %r (mapping %s)" % (what, s.to_original is not None))
    obj.modifiers.remove(mod)
    if operators.live_step(bpy.context, obj) != "setup":
        problem("removing the modifier did not set up again")
    # moving the object is a change of geometry too (its world coordinates),
    # reported by Blender's depsgraph and then hashed
    obj.location.x += 5.0
    moved = operators.live_step(bpy.context, obj)
    obj.location.x -= 5.0
    back = operators.live_step(bpy.context, obj)
    if (moved, back) != ("setup", "setup") or operators.live_step(bpy.context, obj) is not None:
        problem("moving the object gave %r, moving it back %r" % (moved, back))
    # one vertex moved (after the relights' own colour writes, which Blender
    # also reports as geometry updates): a new setup; the light moved: none
    place_light((0, 0.3, 1))
    relit = operators.live_step(bpy.context, obj)
    me.vertices[0].co.x += 0.5
    me.update()
    edited = operators.live_step(bpy.context, obj)
    me.vertices[0].co.x -= 0.5
    me.update()
    place_light((1, 0.3, 0))
    both = operators.live_step(bpy.context, obj)
    report["vertex_moved"] = [relit, edited, both]
    if [relit, edited, both] != ["relight", "setup", "setup"]:
        problem("light, vertex, vertex back with light gave %s" % report["vertex_moved"])
    # a solve of more than 2e5 cells in the background (session.Job, as Solve
    # runs from the panel): this thread, Blender's, keeps running (the
    # library's calls release Python's lock); progress shows, for the factor
    # from inside CHOLMOD's factorization although Blender linked LAPACK
    # before libohm (src/solvers/rebind.h); a cancel ends it with
    # ohm.Cancelled, and the colours and the session are as before, so the
    # next update is a relight, not a setup
    before, runs = luminance().copy(), (s.setups, s.relights)
    obj.ohm.dim = BIG_DIM
    s.begin_run()
    t_gather = time.perf_counter()
    job = session.Job(s, s.gather(obj, sc, bpy.context.evaluated_depsgraph_get()))
    ticks, fractions, t_cancel = [time.perf_counter()], [], None
    report["gather_seconds"] = ticks[0] - t_gather
    while not job.wait(0.0):
        time.sleep(0.01)
        ticks.append(time.perf_counter())
        what, fraction = s.progress
        if what.startswith("solve:") and 0.0 < fraction < 1.0:
            fractions.append((what, fraction))
            if t_cancel is None and fraction > 0.05:
                t_cancel = time.perf_counter()
                job.cancel()
    report["cancel_seconds"] = time.perf_counter() - t_cancel if t_cancel else None
    report["largest_tick_gap_seconds"] = float(np.diff(ticks).max()) if len(ticks) > 1 else None
    report["progress_seen"] = sorted({w for w, f in fractions})
    job.end()
    if not isinstance(job.error, session.ohmlib.Cancelled) or t_cancel is None:
        problem("a background solve of %d^3 ended with %r, cancel asked %s" % (BIG_DIM, job.error, t_cancel))
    if obj.ohm.solver == "direct" and not any(w == "solve: factorize" for w, f in fractions):
        problem("the factorization showed no progress inside Blender: %s" % report["progress_seen"])
    if len(ticks) < 10:
        problem("the main thread ticked %d times during the background solve" % len(ticks))
    obj.ohm.dim = DIM
    if not np.array_equal(luminance(), before) or (s.setups, s.relights) != runs or \
            operators.live_step(bpy.context, obj) is not None:
        problem("a cancelled solve changed the colours or the session")
    place_light((0, 1, 0))
    if operators.live_step(bpy.context, obj) != "relight":
        problem("after a cancelled solve the session did not relight")
    # an Esc that arrives when nothing runs (after the job ended) is aimed at
    # nothing: the next update runs to its end instead of ending "cancelled"
    s.ctx.cancel()
    place_light((1, 0, 0))
    late = operators.live_step(bpy.context, obj)
    if late != "relight" or "cancel" in s.status:
        problem("after a cancel with nothing running, the next update gave %r: %s" % (late, s.status))
    # a panel value that would not fit is refused before anything is built,
    # naming what it needs and the largest Cells that fits
    obj.ohm.dim = 1024
    runs = (s.setups, s.relights)
    t_refuse = time.perf_counter()
    try:
        refused = bpy.ops.ohm.solve() == {"CANCELLED"}
    except RuntimeError:  # an operator's error report, raised in the background
        refused = True
    report["refusal_seconds"] = time.perf_counter() - t_refuse
    report["refusal"] = status()
    m = re.search(r"with solver (\w+) .* the largest Cells that fits is (\d+)", status())
    if not refused or not m or (s.setups, s.relights) != runs:
        problem("Cells 1024 was not refused before a setup: %s" % status())
    else:
        checked, best = m.group(1), int(m.group(2))
        budget = bridge.memory_budget_mb(obj.ohm.max_memory_fraction)[0] * 2 ** 20
        local, tris = bridge.evaluated_mesh(obj, bpy.context.evaluated_depsgraph_get())
        verts = bridge.world_mm(obj, local, bridge.mm_per_unit(sc, obj))

        def asked(dim):  # the library's estimate, as the add-on asks it
            return estimate.ask(s.ctx, verts, tris, dim, checked, 3, budget)
        if SOLVER == "auto" and checked != "mg":
            problem("Auto at Cells 1024 (%d cells) checked %s, not mg" % (asked(1024)["interior_cells"], checked))
        if not (estimate.guarded_bytes(asked(best), checked) <= budget <
                estimate.guarded_bytes(asked(best + 1), checked)):
            problem("the largest Cells named, %d, is not the largest whose prediction fits" % best)
    obj.ohm.dim = DIM
    if SOLVER == "direct":  # the largest Cells a low guard allows: its solve stays under the guard
        guarded_solve()
        runs = (s.setups, s.relights)
    # an accuracy target finer than the memory allows: refused after the
    # library's probes, naming the grid it needs, before that grid is made
    obj.ohm.grid, obj.ohm.error, obj.ohm.max_memory_fraction = "ERROR", 0.002, 0.05
    try:
        refused = bpy.ops.ohm.solve() == {"CANCELLED"}
    except RuntimeError:
        refused = True
    report["error_target_refusal"] = status()
    if not refused or "Cells across" not in status() or (s.setups, s.relights) != runs:
        problem("error=0.002 at 5%% of the memory was not refused before its grid: %s" % status())
    obj.ohm.grid, obj.ohm.max_memory_fraction = "DIM", 0.5
    # a failure reaches the artist: a light inside the object lights
    # nothing, an error that names it (tests/blender_reports.py checks the words)
    place_light((1, 0, 0), distance=1.0)
    try:
        bpy.ops.ohm.solve()
    except RuntimeError:  # the operator's error report
        pass
    report["warnings_light_inside"] = s.warnings
    if not any("No light reaches" in w and "lamp" in w for w in s.warnings):
        problem("a light inside the object gave no error that it lights nothing: %s" % s.warnings)
    place_light((1, 0.3, 0))
    if os.environ.get("OHM_SCREENSHOT"):
        screenshot(os.environ["OHM_SCREENSHOT"], (1, 0.3, 0.4))
    print("ohm live: %d cells, %.1f updates/s, parts (ms) %s" % (report["cells"], report["updates_per_second"],
                                                              report["update_parts_ms"]))
    # deleting the object while a background solve runs: the next depsgraph
    # update cancels the job, and its end closes the session
    s = session.get(obj)
    obj.ohm.dim = min(2 * DIM, BIG_DIM)
    s.begin_run()
    job = session.Job(s, s.gather(obj, sc, bpy.context.evaluated_depsgraph_get()))
    bpy.data.objects.remove(obj)
    bpy.context.view_layer.update()
    ended = job.wait(60.0)
    job.end()
    report["sessions_after_delete"] = len(session._sessions)
    if not ended or session._sessions or s.scene is not None:
        problem("deleting a solving object left %d sessions (job ended %s)" % (len(session._sessions), ended))
elif MODE == "bake":
    sc.frame_start, sc.frame_end = 1, 4
    for f, d in zip(range(1, 5), [(1, 0.3, 0), (0, 0.3, 1), (-1, 0.3, 0), (0, 0.3, -1)]):
        place_light(d)
        lamp.keyframe_insert("location", frame=f)
    obj.ohm.directory = os.path.join(OUT, "")
    sc.frame_set(1)
    if bpy.ops.ohm.bake() != {"FINISHED"}:
        raise SystemExit("ohm.bake did not finish: " + status())
    s = session.get(obj)
    files = [os.path.join(OUT, "spot_%04d.vdb" % f) for f in range(1, 5)]
    report["files"] = [os.path.basename(f) for f in files if os.path.getsize(f) > 0]
    if len(report["files"]) != 4:
        problem("bake wrote %s" % report["files"])
    names = ["%s_%04d" % (obj.ohm.attribute, f) for f in range(1, 5)]
    missing = [n for n in names if n not in me.attributes]
    if missing:
        problem("bake left no attributes %s" % missing)
    report["setups"] = s.setups
    report["relights"] = s.relights
    report["factorizations"] = session.get(obj).factorizations
    if s.setups != 1 or s.relights != 3:
        problem("bake made %d setups and %d relights, expected 1 and 3" % (s.setups, s.relights))
    # frame 1 lit from +x, frame 3 from -x: their attributes say so
    def side_mean(name, sign):
        c = np.empty(4 * len(me.vertices), dtype=np.float32)
        me.attributes[name].data.foreach_get("color", c)
        lum = c.reshape(-1, 4)[:, :3].mean(axis=1)
        return float(lum[sign * verts[:, 0] > 10].mean())
    if not missing:
        f1 = side_mean(names[0], 1) / side_mean(names[0], -1)
        f3 = side_mean(names[2], -1) / side_mean(names[2], 1)
        report["frame_contrasts"] = [f1, f3]
        if not (f1 > 2 and f3 > 2):
            problem("baked frames do not follow the light: %s" % [f1, f3])
    # a light whose power doubles from frame 1 to 2: the exposure is fixed
    # over the bake, so the colours double
    lamp.animation_data_clear()
    place_light((1, 0.3, 0))
    sc.frame_start, sc.frame_end = 1, 2
    for f, watts in ((1, 1.0e4), (2, 2.0e4)):
        lamp_data.energy = watts
        lamp_data.keyframe_insert("energy", frame=f)
    if bpy.ops.ohm.bake() != {"FINISHED"}:
        raise SystemExit("ohm.bake (power) did not finish: " + status())
    mean = [float(np.mean(luminance_of("%s_%04d" % (obj.ohm.attribute, f)))) for f in (1, 2)]
    report["power_doubled_mean_ratio"] = mean[1] / mean[0]
    if abs(mean[1] / mean[0] - 2.0) > 1e-3:
        problem("the light's power doubled, the baked colours went %.4g -> %.4g" % tuple(mean))
    lamp_data.animation_data_clear()
    lamp_data.energy = 2.0e4
    # a static light over the default 250 frames: one frame solved, the
    # earlier bake's files and attributes removed
    sc.frame_start, sc.frame_end = 1, 250
    runs = (s.setups, s.relights)
    if bpy.ops.ohm.bake() != {"FINISHED"}:
        raise SystemExit("ohm.bake (static) did not finish: " + status())
    left = sorted(f for f in os.listdir(OUT) if f.endswith(".vdb"))
    attrs = sorted(a.name for a in me.attributes if a.name.startswith(obj.ohm.attribute + "_"))
    report["static_bake"] = {"files": left, "attributes": attrs,
                             "solves": s.setups + s.relights - runs[0] - runs[1]}
    if left != ["spot_0001.vdb"] or attrs != [obj.ohm.attribute + "_0001"] or report["static_bake"]["solves"] > 1:
        problem("a static light's bake over 250 frames left files %s and attributes %s after %d solves" % (
            left, attrs, report["static_bake"]["solves"]))
    sc.frame_end = 4
    # Solve with a volume object: placed over the mesh, half a voxel back
    obj.ohm.make_volume = True
    sc.frame_set(1)
    if bpy.ops.ohm.solve() != {"FINISHED"}:
        raise SystemExit("ohm.solve (volume) did not finish: " + status())
    vol = bpy.data.objects.get("spot_ohm")
    if vol is None or vol.type != "VOLUME":
        problem("no volume object after Solve with Volume object")
    else:
        h = session.get(obj).scene.grid["voxel"]
        report["volume_location"] = list(vol.location)
        # (Blender keeps the unit scale 0.001 in single precision: 1 unit is 1.00000005 mm)
        if max(abs(x + 0.5 * h) for x in vol.location) > 1e-6 * h:
            problem("volume at %s, expected half a voxel (%g mm) back" % (list(vol.location), h))
        vol.data.grids.load()
        grids = [g.name for g in vol.data.grids]
        report["volume_grids"] = grids
        if not {"fluence_r", "density"} <= set(grids):
            problem("volume grids %s" % grids)
        # the volume alone renders the object: not black, its lit half brighter
        obj.hide_render = True
        place_light((1, 0, 0))
        bpy.ops.ohm.solve()
        vol = bpy.data.objects.get("spot_ohm")
        right, left = report["volume_cycles_right_left"] = cycles_halves(os.path.join(OUT, "volume.png"))
        report["volume_objects"] = [o.name for o in bpy.data.objects if o.type == "VOLUME"]
        if not (right > 1.5 * left and right > 0.02):
            problem("a Cycles render of the volume object: lit half %.4g, far half %.4g" % (right, left))
        if report["volume_objects"] != ["spot_ohm"]:
            problem("a second Solve left volume objects %s" % report["volume_objects"])
        obj.hide_render = False

json.dump(report, open(REPORT, "w"), indent=1)
if report["problems"]:
    raise SystemExit("blender_addon: %d problem(s)" % len(report["problems"]))
print("blender_addon %s: ok" % MODE)
