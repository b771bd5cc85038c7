#!/usr/bin/env python3
"""api_python.py — the Python module (python/ohm) over libohm:
  - errors raise ohm.UsageError / ohm.Error with ohm's message, the very
    line the command line prints after "ohm: error: " (OHM_CLI names it);
  - spot (samples/spot.obj) in marble solves with exact conservation, and
    the log callback hears the run; relight() for new lights reuses the
    factor (the stats' factorization count stays at one per channel),
    conserves power, and equals a fresh scene's solve to 1e-12;
  - a mesh handed over as numpy arrays voxelizes and solves like a file;
  - fluence and exitance come back as [k, j, i] arrays, zero outside the
    object; a density volume as an array voxelizes by threshold like the
    same values read from a raw file;
  - Ctrl-C (SIGINT to this process) during scene.solve() raises
    KeyboardInterrupt, Context.cancel() from another thread ohm.Cancelled,
    an exception in the progress callable reaches the caller, each soon
    after it happens, and the scene then solves; closing a context with a
    live scene closes the scene first.
Run from the repository root with PYTHONPATH naming the built package."""
import ctypes
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

import ohm

failures = 0


def check(cond, what):
    global failures
    if not cond:
        failures += 1
        print("FAIL:", what, file=sys.stderr)


def read_obj(path):
    """spot.obj's vertices and triangles, parsed here independently of ohm."""
    verts, tris = [], []
    for line in open(path):
        w = line.split()
        if w and w[0] == "v":
            verts.append([float(x) for x in w[1:4]])
        elif w and w[0] == "f":
            tris.append([int(x.split("/")[0]) - 1 for x in w[1:4]])
    return np.array(verts), np.array(tris)


def scene_with(ctx, light):
    s = ohm.Scene(ctx)
    s.run("read", file="samples/spot.obj", size=50)
    s.run("voxelize", dim=36)  # 6 500 cells: enough for a relight to solve its media on two threads
    s.run("material", preset="marble")
    s.add_light(**light)
    s.solve(solver="direct")  # the factor, named: its relighting is what is tested (the default is auto)
    return s


def conserves(r):
    return abs(r["power_in"] - r["power_absorbed"] - r["power_out"]) <= 1e-12 * r["power_in"]


# a limit that only catches a call that ran on to its end (seconds, far
# above the ~0.05 s measured; the sanitizers' build runs this too)
SAFETY_S = 20.0


def long_scene(ctx):
    """A scene whose Monte Carlo solve with 1e9 photons would take hours."""
    s = ohm.Scene(ctx)
    s.run("read", file="samples/cow.obj", size=30)
    s.run("voxelize", dim=16)
    s.run("material", preset="marble")
    s.add_light(type="directional", dir=(0, -1, 0))
    return s


def stopped(what, scene, kind, request):
    """Solve for hours unless stopped; request() (None: the solve stops
    itself), made 0.3 s in from another thread, asks it to stop.  Checks
    that `kind` is raised soon after, then that the scene solves."""
    asked = []

    def ask():
        asked.append(time.monotonic())
        request()
    if request:
        threading.Timer(0.3, ask).start()
    t0 = time.monotonic()
    try:
        scene.solve(solver="mc", photons=1e9)
        check(False, "%s: the solve ran to its end" % what)
    except kind:
        took = time.monotonic() - (asked[0] if asked else t0)
        print("%s: %s %.3f s after the request" % (what, kind.__name__, took))
        check(took < SAFETY_S, "%s: took %.1f s" % (what, took))
    scene.solve(solver="mc", photons=10000)
    r = scene.result()
    check(r["power_in"] > 0 and conserves(r), "%s: the scene does not solve afterwards" % what)


def one_progress_bar():
    """A solve of three colour channels, each an iterative solve of its
    own, fills one progress bar: its reports never go back, the first
    channel ends a third of the way, and the last at 1."""
    seen = []
    ctx = ohm.Context(verbosity=0, progress=lambda what, f: seen.append((what, f)))
    with ohm.Scene(ctx) as s:
        s.run("read", file="samples/spot.obj", size=50)
        s.run("voxelize", dim=24)
        s.run("material", preset="skin1")  # three media: one solve per channel
        s.add_light(type="point", pos=(0, 80, 60), intensity=100)
        s.solve(solver="cg")
    solve = [f for what, f in seen if what.startswith("solve")]
    check(len(solve) >= 3 and all(b >= a for a, b in zip(solve, solve[1:])),
          "the solve's progress goes back: %s" % solve)
    check(any(abs(f - 1 / 3) < 1e-9 for f in solve) and solve[-1] == 1.0,
          "the three channels do not share one bar: %s" % solve)
    ctx.close()


def interruptions():
    ctx = ohm.Context(verbosity=0)
    scene = long_scene(ctx)
    # Ctrl-C: SIGINT to this process
    stopped("Ctrl-C", scene, KeyboardInterrupt, lambda: os.kill(os.getpid(), signal.SIGINT))
    # Context.cancel() from another thread
    stopped("Context.cancel()", scene, ohm.Cancelled, ctx.cancel)
    # a cancel while nothing runs is aimed at no call: the next solve runs
    ctx.cancel()
    scene.solve(solver="mc", photons=10000)
    check(conserves(scene.result()), "a solve after a cancel made while nothing ran")

    # an exception in the progress callable
    class Boom(Exception):
        pass

    raised = []

    def progress(what, fraction):
        if "monte carlo" in what and not raised:
            raised.append(what)
            raise Boom(what)
    ctx.set_progress(progress)
    stopped("an exception in progress()", scene, Boom, None)
    ctx.set_progress(None)

    # progress polled from another thread, no callback (Context.poll_progress:
    # the Blender add-on's way): reports seen while the solve runs, then a cancel
    ctx.poll_progress()
    check(ctx.progress() == ("", 0.0), "a fresh polling context reports %s" % (ctx.progress(),))
    seen = []

    def poll_then_cancel():
        t_end = time.monotonic() + SAFETY_S
        while time.monotonic() < t_end and not (seen and seen[-1][0]):
            time.sleep(0.05)
            seen.append(ctx.progress())
        ctx.cancel()
    threading.Thread(target=poll_then_cancel).start()
    try:
        scene.solve(solver="mc", photons=1e9)
        check(False, "polled: the solve ran to its end")
    except ohm.Cancelled:
        pass
    check(seen and "monte carlo" in seen[-1][0] and 0 <= seen[-1][1] < 1,
          "polled progress during the solve: %s" % seen[-3:])
    print("polled progress: %s" % (seen[-1],))
    ctx.set_progress(None)

    # closing the context closes its live scene first (no use after free)
    ctx.close()
    try:
        scene.solve()
        check(False, "a scene of a closed context still ran")
    except ohm.Error as e:
        check("used after close" in str(e), "after Context.close(): %s" % e)


def main():
    check(ohm.version().count(".") == 2, "version %s" % ohm.version())
    messages = []
    with ohm.Context(log=lambda level, text: messages.append((level, text))) as ctx:
        with ohm.Scene(ctx) as bad:
            try:
                bad.run("voxelize", dimm=8)
                check(False, "a misspelled option raised nothing")
            except ohm.UsageError as e:
                check("did you mean 'dim'" in str(e) and e.code == ohm.ERR_USAGE, "usage error: %s" % e)
            try:
                bad.relight()
                check(False, "relight before solve raised nothing")
            except ohm.Error as e:
                check("solve first" in str(e), "relight error: %s" % e)
        try:
            bad.run("voxelize", dim=8)
            check(False, "a closed scene raised nothing")
        except ohm.Error as e:
            check("after close" in str(e), "closed scene: %s" % e)

        # the same failures through the command line: the same message
        cli = os.environ.get("OHM_CLI")
        check(cli is not None, "OHM_CLI names no command line")
        for args, action, opts in [(["-read", "file=nonexist.obj"], "read", dict(file="nonexist.obj")),
                                   (["-voxelize", "dimm=8"], "voxelize", dict(dimm=8)),
                                   (["-read", "file=samples/spot.obj", "-light", "type=spotlight"], None, None)]:
            if not cli:
                break
            printed = subprocess.run([cli] + args, capture_output=True, text=True).stderr.strip().splitlines()[-1]
            with ohm.Scene(ctx) as sc:
                try:
                    if action:
                        sc.run(action, **opts)
                    else:
                        sc.run_args(args)
                    check(False, "%s raised nothing" % args)
                except ohm.Error as e:
                    check(printed == "ohm: error: " + str(e), "API %r, command line %r" % (str(e), printed))

        lights = [dict(type="point", pos=(0, 70, 10), intensity=2000), dict(type="directional", dir=(1, 0, -0.5)),
                  dict(type="point", pos=(-60, 5, 20), intensity=2000)]
        with scene_with(ctx, lights[0]) as s:
            r = s.result()
            check(r["factorizations"] == 3 and r["channels"] == 3, "first solve: %s" % r)
            # the result's members are the ones the library describes (ohm_struct_members), all of them
            described = [name for name, _ in ohm._ResultInfo._fields_ if name != "size" and not name.startswith("_pad")]
            check(list(r) == described and len(described) == 13 and ctypes.sizeof(ohm._ResultInfo) >= 104,
                  "result members %s" % list(r))
            check(r["power_in"] > 0 and conserves(r), "conservation %s" % r)
            check(any("solved" in text for _, text in messages), "the log callback heard no solve")
            phi, ex, inside = s.fluence(), s.exitance(2), s.inside()
            g = s.grid
            check(phi.shape == (g["dims"][2], g["dims"][1], g["dims"][0]), "fluence shape %s" % (phi.shape,))
            check(np.all(phi[~inside] == 0) and np.all(ex[~inside] == 0) and (phi[inside] > 0).all(),
                  "fluence positive inside, zero outside")
            check(s.stat("solver") == "direct" and s.stat("power_out") == r["power_out"], "stats")
            vx = s.vertex_exitance()
            check(vx.shape[1] == 3 and (vx > 0).mean() > 0.25, "vertex exitance %s" % (vx.shape,))
            setup_keys = ("t_network", "t_assemble", "t_analyze", "t_factor", "t_shadow_setup", "t_clear")
            setup = {k: s.stat(k) for k in setup_keys}
            check(setup["t_factor"] > 0, "the solve's factor time booked: %s" % setup)
            for light in lights[1:]:
                s.clear_lights()
                s.add_light(**light)
                s.relight()
                rr = s.result()
                check(rr["factorizations"] == 3, "relight factored again: %s" % rr)
                # a relight sets nothing up: the set-up times are the solve's, not added again
                check({k: s.stat(k) for k in setup_keys} == setup,
                      "a relight booked set-up time: %s, was %s" % ({k: s.stat(k) for k in setup_keys}, setup))
                check(rr["power_in"] > 0 and conserves(rr), "relit conservation %s" % rr)
                check(s.stat("factors") == 3, "the stats count %s factorizations" % s.stat("factors"))
                with scene_with(ctx, light) as fresh:
                    for c in range(3):
                        a, b = s.fluence(c), fresh.fluence(c)
                        diff = np.abs(a - b).max() / np.abs(b).max()
                        check(diff <= 1e-12, "relight channel %d differs from a fresh solve by %.3g" % (c, diff))
            # the three media solved at once (keep=1, more than one core) give
            # the same bits as one after another (one core allowed)
            cores = os.sched_getaffinity(0)
            if len(cores) > 1:
                check(s.stat("solve_threads") == 2, "relight on %d cores: solve_threads %s" %
                      (len(cores), s.stat("solve_threads")))
                together = [s.fluence(c) for c in range(3)]
                os.sched_setaffinity(0, {min(cores)})
                try:
                    s.relight()
                finally:
                    os.sched_setaffinity(0, cores)
                check(s.stat("solve_threads") == 1, "relight on one core: solve_threads %s" % s.stat("solve_threads"))
                for c in range(3):
                    check(np.array_equal(s.fluence(c), together[c]),
                          "channel %d solved with the others differs from solved alone" % c)
            else:
                print("api_python: one core: the media are never solved together here")

        # the library's estimate of a solve, before anything is built (what
        # the Blender add-on asks): its memory per solver and auto's choice
        with ohm.Scene(ctx) as e:
            e.run("read", file="samples/spot.obj", size=50)
            small, big = e.estimate(dim=16, solves=1000), e.estimate(dim=64, solver="mg")
            check(small["solver"] == "direct" and "predicted" in small["reason"] and small["margin"] > 1,
                  "auto for many relights of a small grid: %s" % small)
            check(big["solver"] == "mg" and big["reason"] == "asked for" and big["bytes_mg"] > small["bytes_mg"] and
                  big["interior_cells"] > small["interior_cells"] > 0, "mg at dim 64: %s" % big)
            try:
                e.estimate(solver="mg")
                check(False, "an estimate without dim= ran")
            except ohm.UsageError as x:
                check("needs dim=" in str(x), "estimate without dim=: %s" % x)

        # a mesh as arrays: the same object and solution as the file
        verts, tris = read_obj("samples/spot.obj")
        with ohm.Scene(ctx) as a, ohm.Scene(ctx) as b:
            a.set_mesh(verts, tris, name="spot arrays")
            b.run("read", file="samples/spot.obj")
            for x in (a, b):
                x.run("voxelize", dim=16)
                x.run("material", preset="skin1")
                x.add_light(type="directional", dir=(0, -1, 0))
                x.solve()
            check(a.grid == b.grid and (a.inside() == b.inside()).all(), "arrays %s, file %s" % (a.grid, b.grid))
            check(np.abs(a.fluence() - b.fluence()).max() <= 1e-12 * np.abs(b.fluence()).max(), "arrays' fluence")

        # a density volume: array and raw file give the same object
        n = 12
        vol = np.zeros((n, n, n), dtype=np.float32)
        vol[4:8, 2:10, 3:9] = 100.0  # [k, j, i]
        with tempfile.TemporaryDirectory() as tmp:
            raw = os.path.join(tmp, "box.raw")
            vol.tofile(raw)
            with ohm.Scene(ctx) as a, ohm.Scene(ctx) as b:
                a.set_density(vol, [[2, 0, 0, 0], [0, 2, 0, 0], [0, 0, 2, 0]], name="box")
                b.run("read", file=raw, dims=(n, n, n), type="f32", spacing=2)
                for x in (a, b):
                    x.run("voxelize", threshold=50, voxel=0.5)
                check(a.grid == b.grid and (a.inside() == b.inside()).all(), "array %s, file %s" % (a.grid, b.grid))
                volume = a.grid["interior_cells"] * 0.5 ** 3
                check(abs(volume - 12 * 16 * 8) <= 0.25 * 832, "object %.1f mm^3 against the 1536 mm^3 box" % volume)
            # a uniform array is its box (22 mm a side between its outermost
            # voxel centres), never the grid's margin (docs/scans.md)
            with ohm.Scene(ctx) as u:
                u.set_density(np.full((n, n, n), 100.0, dtype=np.float32), [[2, 0, 0, 0], [0, 2, 0, 0], [0, 0, 2, 0]])
                u.run("voxelize", threshold=50, voxel=1)
                cells = u.grid["interior_cells"]
                check(cells == 22 ** 3, "uniform array: %d cells, expected 22^3" % cells)
    one_progress_bar()
    interruptions()
    print("api_python: %d failure(s)" % failures)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
