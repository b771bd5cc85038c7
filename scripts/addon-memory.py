#!/usr/bin/env python3
"""addon-memory.py — the memory predictions the Blender add-on asks of the
library (ohm_scene_estimate, through blender/ohm_blender/estimate.py) against measured peaks: each case runs, in
a fresh process, the library calls the add-on's Solve makes (read the mesh,
a measured preset, a point light, voxelize at Cells, solve keeping the
solver), and reports the process's peak resident memory beside the
prediction.  Prints a Markdown table (docs/blender.md holds a measured one);
it asserts nothing.  Takes about 4 minutes and up to ~8 GB at the largest
case.

  /usr/bin/python3 scripts/addon-memory.py [BUILD_DIR]
"""
import gzip
import importlib.util
import json
import os
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build")
os.environ.setdefault("OHM_LIBRARY", os.path.join(BUILD, "libohm.so"))
sys.path.insert(0, os.path.join(ROOT, "python"))
import ohm  # noqa: E402  (the library's own estimate, ohm_scene_estimate: what the add-on asks)
CTX = ohm.Context(verbosity=0)
spec = importlib.util.spec_from_file_location("estimate", os.path.join(ROOT, "blender", "ohm_blender", "estimate.py"))
estimate = importlib.util.module_from_spec(spec)
spec.loader.exec_module(estimate)

CASES = [("larger_sphere.off", 40, 96, "direct"),
         ("spot.obj", 50, 96, "direct"), ("spot.obj", 50, 128, "direct"),
         ("stanford-bunny.obj.gz", 50, 128, "direct"), ("teapot.obj", 50, 128, "direct"),
         ("knot1.off", 50, 128, "direct"),
         ("larger_sphere.off", 40, 200, "mg"), ("larger_sphere.off", 40, 320, "mg"), ("spot.obj", 50, 320, "mg"),
         ("teapot.obj", 50, 256, "mg"), ("knot1.off", 50, 256, "mg"), ("spot.obj", 50, 200, "cg"),
         ("spot.obj", 50, 200, "auto"), ("spot.obj", 50, 96, "auto")]

CHILD = r"""
import json, os, resource, sys
sys.path.insert(0, os.path.join(sys.argv[1], "python"))
import ohm
mesh, size, dim, solver = sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
sc = ohm.Scene(ohm.Context(verbosity=0))
sc.run("read", file=mesh, size=size)
sc.run("material", preset="marble")
sc.add_light(type="point", pos=(0, 100, 0), intensity=1000)
sc.run("voxelize", dim=dim)
sc.solve(solver=solver)
print(json.dumps({"cells": sc.grid["interior_cells"], "solver": sc.stat("solver"),
                  "peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0}))
"""


def read_mesh(path):
    """vertices (n, 3) and triangles (m, 3) of an .obj or .off (gzipped or not)."""
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        text = f.read().split("\n")
    verts, tris = [], []
    if path.replace(".gz", "").endswith(".off"):
        words = " ".join(line.split("#")[0] for line in text).split()
        nv, nf = int(words[1]), int(words[2])
        verts = np.array(words[4:4 + 3 * nv], dtype=float).reshape(-1, 3)
        k = 4 + 3 * nv
        for _ in range(nf):
            c = int(words[k])
            face = [int(w) for w in words[k + 1:k + 1 + c]]
            tris += [(face[0], face[i], face[i + 1]) for i in range(1, c - 1)]
            k += 1 + c
        return verts, np.array(tris, dtype=np.int64)
    for line in text:
        t = line.split()
        if t and t[0] == "v":
            verts.append([float(x) for x in t[1:4]])
        elif t and t[0] == "f":
            face = [int(w.split("/")[0]) - 1 for w in t[1:]]
            tris += [(face[0], face[i], face[i + 1]) for i in range(1, len(face) - 1)]
    return np.array(verts), np.array(tris, dtype=np.int64)


print("| mesh | Cells | solver (chosen) | interior cells (predicted) | peak measured | predicted | predicted / measured |")
print("|---|---:|---|---:|---:|---:|---:|")
env = dict(os.environ, OHM_LIBRARY=os.path.join(BUILD, "libohm.so"))
for name, size, dim, solver in CASES:
    verts, tris = read_mesh(os.path.join(ROOT, "samples", name))
    verts = verts * (size / np.ptp(verts, axis=0).max())
    est = estimate.ask(CTX, verts, tris, dim, solver, 3, 1e15)
    predicted = est["bytes_" + solver]
    out = subprocess.run([sys.executable, "-c", CHILD, ROOT, os.path.join(ROOT, "samples", name), str(size), str(dim),
                          solver], env=env, capture_output=True, text=True)
    if out.returncode != 0:
        print("| %s | %d | %s | | failed: %s | | |" % (name, dim, solver, out.stderr.strip().splitlines()[-1][:80]))
        continue
    r = json.loads(out.stdout.strip().splitlines()[-1])
    print("| %s | %d | %s (%s) | %d (%d) | %s | %s | %.2f |" % (
        name, dim, solver, r["solver"], r["cells"], est["interior_cells"], estimate.gib(r["peak"]),
        estimate.gib(predicted), predicted / r["peak"]), flush=True)
