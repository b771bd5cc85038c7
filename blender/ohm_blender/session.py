"""One object's ohm scene, kept between operator calls: the solver lives
here, so Live relight and Bake solve new lights without setting up again,
and only a change of geometry or material sets up anew.

Blender's operators are stateless, so the sessions are kept in this module,
keyed by the object's address in memory (obj.as_pointer()): a rename keeps
its session.  Sessions of objects that are gone (deleted, or reallocated
by an undo) are closed on the next depsgraph update (prune), all of them
when a file is loaded and when the add-on is unregistered (close_all).
Nothing here is saved in the .blend: status, warnings and rates are
runtime state.

A setup is three steps, so that the long one can run off Blender's UI
thread: gather (Blender's data, on the main thread), compute (only library
calls: any thread; Job runs it on one), finish (writing the colours back,
on the main thread)."""
import hashlib
import threading
import time

import numpy as np

from . import bridge, estimate

try:  # the package bundled into the add-on's zip (lib/libohm.so.1 beside it)
    from . import ohm as ohmlib
except ImportError:  # running from a source tree with ohm on sys.path
    import ohm as ohmlib

_sessions = {}


def key(obj):
    return obj.as_pointer()


def get(obj):
    return _sessions.get(key(obj))


def get_or_create(obj):
    s = _sessions.get(key(obj))
    if s is None:
        s = _sessions[key(obj)] = Session(obj.name)
    return s


def close_all():
    for s in _sessions.values():
        s.close()
    _sessions.clear()


def prune(objects):
    """Close the sessions of objects no longer among `objects` (a running
    job is cancelled, and Job.end closes its session)."""
    alive = {o.as_pointer() for o in objects}
    for k in [k for k in _sessions if k not in alive]:
        s = _sessions.pop(k)
        if s.job is not None:
            s.job.cancel()
        else:
            s.close()


def mark_geometry(depsgraph):
    """Blender's depsgraph reported these updates: note the sessions whose
    object's geometry or placement changed (needs_setup hashes it then)."""
    for update in depsgraph.updates:
        if update.is_updated_geometry or update.is_updated_transform:
            s = _sessions.get(getattr(update.id, "original", update.id).as_pointer())
            if s is not None:
                s.geometry_reported = True


def _settings_signature(obj, bscene):
    """What a change of the object's setup is: the settings that shape the
    network (not exposure, attribute or output folder: they need no solve)."""
    st = obj.ohm
    return (bridge.mm_per_unit(bscene, obj), st.material, st.preset, tuple(st.sigma_a), tuple(st.sigma_s),
            st.eta, st.volume_path, st.transfer_path, st.grid, st.dim, st.error, st.boundary, st.solver,
            st.device, st.shadows)


def _channels(st):
    """Distinct channels, each its own solver (a factor or a hierarchy)."""
    if st.material == "COEFFICIENTS":
        return len(set(zip(tuple(st.sigma_a), tuple(st.sigma_s))))
    return 3


class DarkResult(ohmlib.Error):
    """A solve whose light reaches no part of the object (0 W leave it):
    a failure, not a black object (messages.py words it)."""

    def __init__(self, name):
        super().__init__(ohmlib.ERR_INVALID, "no light reaches %s: power out 0 W" % name)


def check_lit(sc, name):
    """DarkResult when no light leaves the scene's object."""
    if not sc.result()["power_out"] > 0:
        raise DarkResult(name)


def geometry_hash(verts, tris):
    """The evaluated mesh exactly: its coordinates and its triangles."""
    h = hashlib.blake2b(digest_size=16)
    h.update(np.ascontiguousarray(verts).tobytes())
    h.update(np.ascontiguousarray(tris).tobytes())
    return h.hexdigest()


class Session:
    def __init__(self, name):
        self.name = name
        self.messages = []        # (level, text) of the current run
        # progress is polled (Context.progress), not called back: a Python
        # callback on the solving thread needs Python's lock, which Blender's
        # main thread holds (measured under Xvfb, with the same redraws: 44 s
        # with callbacks, 23 s polled)
        self.ctx = ohmlib.Context(verbosity=1, log=self._log)
        self.ctx.poll_progress()
        self.scene = None
        self.signature = None     # (settings, geometry hash) the solver was set up for
        self.lights = None        # lights signature of the current solution
        self.last = {}            # the latest update's timings (s)
        self.setups = 0
        self.relights = 0
        self.factorizations = 0
        self.solver = ""          # the backend that solved last
        self.solver_note = ""     # why, when the panel said Auto
        self.status = ""          # one line for the panel
        self.warnings = []        # the last run's warnings' headlines
        self.notes = []           # the last run's messages (messages.Note), for the panel
        self.updates_per_second = 0.0
        self.exposure = None      # the exposure the colours were written with
        self.auto_exposure = None  # Exposure 0's: chosen from the first result, kept (choose_exposure)
        self.mm_per_unit = None   # the Scale the solver was set up at (relights place the lights with it)
        self.to_original = None   # the evaluated vertex each of the mesh's own vertices shows
        self.geometry_reported = True  # Blender reported the geometry or placement changed
        self.result = None
        self.job = None           # a Job running on this session

    def _log(self, level, text):
        self.messages.append(("WARNING" if level == ohmlib.LOG_WARNING else "INFO", text))
        del self.messages[:-200]

    @property
    def progress(self):
        """The library's latest (what, fraction), from any thread."""
        return self.ctx.progress()

    def begin_run(self):
        """A new operator run: its messages and progress start empty."""
        self.messages = []
        self.ctx.poll_progress()

    def run_warnings(self):
        return [text for level, text in self.messages if level == "WARNING"]

    def close(self):
        if self.scene is not None:
            self.scene.close()
            self.scene = None
        self.ctx.close()

    # ---- a setup, in three steps -------------------------------------------

    def gather(self, obj, bscene, depsgraph):
        """Everything a setup needs from Blender, read now (main thread)."""
        import bpy
        st = obj.ohm
        mm = bridge.mm_per_unit(bscene, obj)
        lights = bridge.scene_lights(bscene, mm)
        if not lights:
            raise ohmlib.UsageError(ohmlib.ERR_USAGE, "the scene has no point, sun, spot or area light, and its World does not light it")
        local, tris = bridge.evaluated_mesh(obj, depsgraph)
        verts = bridge.world_mm(obj, local, mm)
        budget_mb, available_mb = bridge.memory_budget_mb(st.max_memory_fraction)
        solver, self.solver_note = st.solver, ""
        budget = budget_mb * 2 ** 20
        if st.grid == "DIM":  # (an accuracy target's grid is the library's to choose, and check)
            est = estimate.ask(self.ctx, verts, tris, st.dim, solver, _channels(st), budget)
            if solver == "auto":  # the library's choice, for the relights to come
                solver = est["solver"]
                self.solver_note = "Auto: %s (%s)" % (solver, est["reason"])
            refusal = estimate.check(est, st.dim, solver, budget,
                                     "%d%% of the %s available" % (round(100 * st.max_memory_fraction),
                                                                   estimate.gib(available_mb * 2 ** 20)))
            if refusal:
                raise ohmlib.UsageError(ohmlib.ERR_USAGE, refusal)
        else:  # the library picks the grid: it refuses one finer than what fits (max_dim=), after its probes
            limit_solver = "mg" if solver == "auto" else solver
            max_dim = estimate.ask(self.ctx, verts, tris, 4, limit_solver, _channels(st), budget)["largest_dim"]
            if max_dim < 4:
                raise ohmlib.UsageError(ohmlib.ERR_USAGE, "no grid with solver %s fits the %s Memory allows" % (
                    limit_solver, estimate.gib(budget_mb * 2 ** 20)))
        job = {"verts": verts, "tris": tris, "to_original": bridge.to_original(obj, local), "name": obj.name,
               "lights": lights, "mm_per_unit": mm,
               "material": st.material, "preset": st.preset, "sigma_a": tuple(st.sigma_a),
               "sigma_s": tuple(st.sigma_s), "eta": st.eta, "grid": st.grid, "dim": st.dim, "error": st.error,
               "boundary": st.boundary, "solver": solver, "shadows": st.shadows, "device": st.device,
               "max_memory_mb": budget_mb, "max_dim": None if st.grid == "DIM" else max_dim,
               "signature": (_settings_signature(obj, bscene), geometry_hash(verts, tris)),
               "lights_signature": bridge.lights_signature(bscene)}
        if st.material == "VOLUME":
            job["volume"] = bpy.path.abspath(st.volume_path)
            job["transfer"] = bpy.path.abspath(st.transfer_path)
        return job

    def compute(self, job):
        """Voxelize, set the material and lights, set up the solver and
        solve: library calls only, so any thread may run this.  The new
        scene goes into job["scene"]; the session keeps its old one until
        finish, so that a cancelled or failed setup leaves it as it was."""
        t0 = time.perf_counter()
        sc = ohmlib.Scene(self.ctx)
        try:
            self._compute(sc, job)
        except BaseException:
            sc.close()
            raise
        job["scene"] = sc
        job["seconds"] = time.perf_counter() - t0

    def _compute(self, sc, job):
        _go_on(job)
        sc.set_mesh(job["verts"], job["tris"], name=job["name"])
        _go_on(job)
        if job["material"] == "PRESET":
            sc.run("material", preset=job["preset"])
        elif job["material"] == "COEFFICIENTS":
            sc.run("material", sigma_a=job["sigma_a"], sigma_s=job["sigma_s"], eta=job["eta"])
        else:
            sc.run("read", file=job["volume"])
            sc.run("place")
            sc.run("material", transfer=job["transfer"])
        for opts in job["lights"]:
            sc.add_light(**opts)
        _go_on(job)
        memory = {"max_memory": job["max_memory_mb"]}
        if job["grid"] == "DIM":
            sc.run("voxelize", dim=job["dim"], **memory)
        else:
            sc.run("voxelize", error=job["error"], max_dim=job["max_dim"], **memory)
        _go_on(job)
        # the device runs mg's solve only (Auto's choice is made by then: gather)
        device = {"device": job["device"]} if job["solver"] == "mg" and job["device"] != "host" else {}
        sc.solve(boundary=job["boundary"], solver=job["solver"], shadows="mesh" if job["shadows"] else "none",
                 **memory, **device)
        check_lit(sc, job["name"])
        job["exitance"] = sc.vertex_exitance()

    def finish(self, obj, job):
        """The solved setup's scene replaces the old one, and its colours
        go onto the mesh (main thread)."""
        if self.scene is not None:
            self.scene.close()
        self.scene = job.pop("scene")
        self.signature = job["signature"]
        self.lights = job["lights_signature"]
        self.setups += 1
        self.last = {"setup": job["seconds"]}
        self.to_original = job["to_original"]
        self.mm_per_unit = job["mm_per_unit"]
        self._write(obj, job["exitance"])
        return self.last

    def setup(self, obj, bscene, depsgraph):
        """gather, compute and finish on this thread."""
        job = self.gather(obj, bscene, depsgraph)
        self.compute(job)
        return self.finish(obj, job)

    # ---- relighting ----------------------------------------------------------

    def relight_gather(self, bscene):
        """A relight's inputs from Blender (main thread): the lights as they are now."""
        lights = bridge.scene_lights(bscene, self.mm_per_unit)
        if not lights:
            raise ohmlib.UsageError(ohmlib.ERR_USAGE, "the scene has no point, sun, spot or area light, and its World does not light it")
        return {"lights": lights, "lights_signature": bridge.lights_signature(bscene)}

    def relight_compute(self, job):
        """The lights solved with the kept solver: library calls only, any thread."""
        sc = self.scene
        t_source0, t_solve0 = sc.stat("t_source"), sc.stat("t_solve")
        t0 = time.perf_counter()
        _go_on(job)
        sc.clear_lights()
        for opts in job["lights"]:
            sc.add_light(**opts)
        _go_on(job)
        sc.relight()
        check_lit(sc, self.name)
        t1 = time.perf_counter()
        job["exitance"] = sc.vertex_exitance()
        job["last"] = {"source_and_shadows": sc.stat("t_source") - t_source0, "solve": sc.stat("t_solve") - t_solve0,
                       "relight_call": t1 - t0, "vertex_exitance": time.perf_counter() - t1}
        job["t0"] = t0

    def relight_finish(self, obj, job):
        """The relit colours onto the mesh (main thread)."""
        self.lights = job["lights_signature"]
        self.relights += 1
        self.last = job["last"]
        self._write(obj, job["exitance"])
        self.last["total"] = time.perf_counter() - job["t0"]
        return self.last

    def relight(self, obj, bscene, depsgraph):
        """The scene's lights as they are now, solved with the kept solver,
        on this thread."""
        job = self.relight_gather(bscene)
        self.relight_compute(job)
        return self.relight_finish(obj, job)

    def lights_changed(self, bscene):
        return bridge.lights_signature(bscene) != self.lights

    def needs_setup(self, obj, bscene, depsgraph):
        """A new setup is due: the settings changed, or the geometry did.
        The geometry is hashed only after Blender reported an update of the
        object's geometry or placement (mark_geometry): hashing a large
        evaluated mesh on every tick of Live relight's timer would take the
        main thread's time; the hash, not the report, decides."""
        if self.scene is None or self.signature is None:
            return True
        if _settings_signature(obj, bscene) != self.signature[0]:
            return True
        if not self.geometry_reported:
            return False
        self.geometry_reported = False
        local, tris = bridge.evaluated_mesh(obj, depsgraph)
        return geometry_hash(bridge.world_mm(obj, local, bridge.mm_per_unit(bscene, obj)), tris) != self.signature[1]

    def update(self, obj, bscene, depsgraph):
        """What changed since the last solve: 'setup' (geometry or material:
        a new solver), 'relight' (lights only), or None."""
        if self.needs_setup(obj, bscene, depsgraph):
            self.setup(obj, bscene, depsgraph)
            return "setup"
        if self.lights_changed(bscene):
            self.relight(obj, bscene, depsgraph)
            return "relight"
        return None

    def recolour(self, obj):
        """The colour attribute again from the current solution (after a
        change of exposure or attribute name: no solve)."""
        if self.scene is None or self.job is not None:
            return
        self._write(obj, self.scene.vertex_exitance())

    def choose_exposure(self):
        """Exposure 0's anew from the current result (the Auto exposure
        button): its brightest 1% white.  None without a result."""
        if self.scene is None or self.job is not None:
            return None
        self.auto_exposure = bridge.exposure_for(self.mesh_exitance(), 0.0)
        return self.auto_exposure

    def mesh_exitance(self, exitance=None):
        """The exitance (vertices, channels) at the mesh's own vertices: the
        library's per evaluated vertex, mapped (bridge.to_original)."""
        if exitance is None:
            exitance = self.scene.vertex_exitance()
        return exitance if self.to_original is None else exitance[self.to_original]

    def _write(self, obj, exitance):
        """exitance per evaluated vertex onto the mesh's own vertices.
        Blender reports the attribute written as an update of the object's
        geometry, and needs_setup would hash the mesh again after every
        relight (1.4 ms of a 20 ms update at 3e4 cells): the depsgraph is
        evaluated before the write, so that a real edit still pending is
        reported and kept, and after it, so that the write's own report is
        dropped."""
        import bpy
        t0 = time.perf_counter()
        exitance = self.mesh_exitance(exitance)
        bpy.context.evaluated_depsgraph_get()
        reported = self.geometry_reported
        if self.auto_exposure is None:  # the first result chooses Exposure 0's, for every update after it
            self.auto_exposure = bridge.exposure_for(exitance, 0.0)
        self.exposure = bridge.write_colours(obj, obj.ohm.attribute, exitance, obj.ohm.exposure or self.auto_exposure)
        bpy.context.evaluated_depsgraph_get()
        self.geometry_reported = reported
        self.last["attribute_write"] = time.perf_counter() - t0
        r = self.result = self.scene.result()
        self.factorizations = r["factorizations"]
        self.solver = self.scene.stat("solver") if r["solves"] else ""
        if self.solver == "mg" and self.scene.stat("device") != "host":
            self.solver += " on " + self.scene.stat("device")


def _go_on(job):
    """Raise ohm.Cancelled when the job was cancelled.  The library drops a
    cancel made while none of its calls runs (ohm.h: a request applies to
    the call running), so a job of several calls checks between them.  (A
    synchronous setup or relight has no Job, and nothing to cancel it.)"""
    cancelled = job.get("cancelled")
    if cancelled is not None and cancelled.is_set():
        raise ohmlib.Cancelled(ohmlib.ERR_CANCELLED, "cancelled")


class Job:
    """A compute step (a setup's, or with compute=Session.relight_compute a
    relight's) on a thread of its own, so that Blender's window stays
    responsive; cancel() stops it within about a second (the library's
    cancellation).  The operator's timer polls done()."""

    def __init__(self, s, job, compute=None):
        self.session, self.job = s, job
        self.compute = compute or s.compute
        self.kind = "relight" if compute == s.relight_compute else "setup"
        self.error = None
        job["cancelled"] = threading.Event()
        s.job = self
        self.thread = threading.Thread(target=self._run, name="ohm %s %s" % (self.kind, s.name), daemon=True)
        self.t0 = time.perf_counter()
        self.thread.start()

    def _run(self):
        try:
            self.compute(self.job)
        except Exception as e:  # handed to the main thread, which reports it
            self.error = e

    def done(self):
        return not self.thread.is_alive()

    def cancel(self):
        self.job["cancelled"].set()
        self.session.ctx.cancel()

    def wait(self, seconds=None):
        self.thread.join(seconds)
        return self.done()

    def end(self):
        """The job is over (joined): the session may run again, or, when
        its object went while the job ran (prune), is closed."""
        self.thread.join()
        s = self.session
        s.job = None
        if not any(x is s for x in _sessions.values()):
            if "scene" in self.job:  # a setup that finished for an object that is gone
                self.job.pop("scene").close()
            s.close()
