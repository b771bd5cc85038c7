"""light_environment_fronts.py — the same environment-lit scene from the
command line, from Python and from the Blender add-on gives the same fluence
(tests/cli_light_environment.sh):

  python3 tests/light_environment_fronts.py OUTDIR NAME...

For each NAME: OUTDIR/NAME.json holds the light's options (as the add-on made
them, or as the shell test wrote them); OUTDIR/mesh.obj the object;
OUTDIR/NAME.csv the command line's cells (-export csv=); OUTDIR/NAME.npy,
when there, the add-on's fluence [c, k, j, i].  This script solves the same
scene through the Python package (the add-on's calls: set_mesh, material,
the light, voxelize, solve) and checks every pair cell by cell, to 1e-9 of
the peak.  Exits 1 on a difference."""
import json
import os
import sys

import numpy as np

import ohm

OUT, NAMES = sys.argv[1], sys.argv[2:]
failures = 0


def read_obj(path):
    verts, tris = [], []
    for line in open(path):
        t = line.split()
        if t and t[0] == "v":
            verts.append([float(x) for x in t[1:4]])
        elif t and t[0] == "f":
            idx = [int(w.split("/")[0]) - 1 for w in t[1:]]
            tris += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    return np.array(verts), np.array(tris)


def python_fluence(light):
    verts, tris = read_obj(os.path.join(OUT, "mesh.obj"))
    with ohm.Context(verbosity=0) as ctx, ohm.Scene(ctx) as sc:
        sc.set_mesh(verts, tris)
        sc.run("material", preset="marble")
        sc.add_light(**light)
        sc.run("voxelize", dim=24)
        sc.solve(solver="direct", shadows="mesh")
        g = sc.grid
        return np.stack([sc.fluence(channel=c) for c in range(sc.result()["channels"])]), g


def cli_fluence(path, shape, channels):
    """The -export csv= cells (i, j, k, x, y, z, fluence per channel, ...) on the grid."""
    phi = np.zeros((channels,) + shape)
    for line in open(path):
        if not line[:1].isdigit():
            continue
        t = line.split(",")
        i, j, k = int(t[0]), int(t[1]), int(t[2])
        for c in range(channels):
            phi[c, k, j, i] = float(t[6 + c])
    return phi


def compare(what, a, b):
    global failures
    if a.shape != b.shape:
        print("FAIL: %s: shapes %s and %s" % (what, a.shape, b.shape))
        failures += 1
        return
    diff = float(np.abs(a - b).max()) / float(np.abs(b).max())
    print("%s: largest difference %.3g of the peak %.6g W/mm^2" % (what, diff, float(np.abs(b).max())))
    if not (diff <= 1e-9 and np.abs(b).max() > 0):
        print("FAIL: %s differ by %.3g of the peak" % (what, diff))
        failures += 1


for name in NAMES:
    light = json.load(open(os.path.join(OUT, name + ".json")))
    py, g = python_fluence(light)
    nx, ny, nz = g["dims"]
    cli = cli_fluence(os.path.join(OUT, name + ".csv"), (nz, ny, nx), py.shape[0])
    compare(name + ": command line vs Python", cli, py)
    addon = os.path.join(OUT, name + ".npy")
    if os.path.exists(addon):
        compare(name + ": add-on vs Python", np.load(addon), py)
sys.exit(1 if failures else 0)
