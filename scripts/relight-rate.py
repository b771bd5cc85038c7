#!/usr/bin/env python3
"""relight-rate.py — the library's relight rate with a kept solver
(docs/multigrid.md, "Live relight"): Spot (50 mm) in marble at dim 128
(297 250 cells, three channels), a point light 110 mm away moved by STEP
degrees around the vertical axis per update, through the Python package
(Scene.relight: keep=1); prints the first solve and the median of 20
relights.  DIM (default 128) sets the grid.  It reports; it asserts nothing.

  /usr/bin/python3 scripts/relight-rate.py SOLVER STEP [CG_TOL|-] [BUILD] [DIM]
"""
import math
import os
import statistics
import sys
import time

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
solver, step = sys.argv[1], float(sys.argv[2])
tol = sys.argv[3] if len(sys.argv) > 3 and sys.argv[3] != "-" else None
build = sys.argv[4] if len(sys.argv) > 4 and sys.argv[4] != "-" else os.path.join(root, "build")
dim = int(sys.argv[5]) if len(sys.argv) > 5 else 128
os.environ.setdefault("OHM_LIBRARY", os.path.join(build, "libohm.so"))
sys.path.insert(0, os.path.join(root, "python"))
import ohm  # noqa: E402


def light(degrees):
    a = math.radians(degrees)
    return dict(type="point", pos=(110 * math.cos(a), 30, 110 * math.sin(a)), intensity=2000)


ctx = ohm.Context(verbosity=0)
sc = ohm.Scene(ctx)
sc.run("read", file=os.path.join(root, "samples", "spot.obj"), size=50)
sc.run("material", preset="marble")
sc.add_light(**light(0))
sc.run("voxelize", dim=dim)
opts = dict(solver=solver)
if tol:
    opts["cg_tol"] = tol
t0 = time.perf_counter()
sc.solve(**opts)
first = time.perf_counter() - t0
times = []
for k in range(1, 21):
    sc.clear_lights()
    sc.add_light(**light(step * k))
    t0 = time.perf_counter()
    sc.relight()
    times.append(time.perf_counter() - t0)
median = statistics.median(times)
print("| %s%s | %g° | %d | %.2f s | %.3f s | %.1f |" % (
    solver, ", cg_tol=" + tol if tol else "", step, sc.result()["unknowns"], first, median, 1.0 / median))
