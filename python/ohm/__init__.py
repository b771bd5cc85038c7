"""ohm — subsurface light scattering in voxel volumes, from Python.

A thin layer over libohm's C API (include/ohm.h, whose comments are the
manual): a Context holds verbosity and the log and progress callbacks; a
Scene holds one object and its light — mesh or density volume, voxel grid,
material, lights — and the solver set up for them (solver=auto unless asked),
kept so that relight() solves new lights without setting up again.

    import ohm
    with ohm.Context() as ctx, ohm.Scene(ctx) as scene:
        scene.run("read", file="samples/spot.obj", size=50)
        scene.run("voxelize", dim=64)
        scene.run("material", preset="marble")
        scene.add_light(type="directional", dir=(0, -1, -1))
        scene.solve()
        phi = scene.fluence(channel=0)           # numpy, shape (nz, ny, nx)
        scene.clear_lights()
        scene.add_light(type="point", pos=(0, 80, 40), intensity=5000)
        scene.relight()                          # no new set-up

Steps are ohm's pipeline actions (`ohm help`, `ohm help ACTION`), their
options keyword arguments (a tuple or list becomes "x,y,z").  Arrays over
the grid are indexed [k, j, i] (x fastest in memory, as ohm stores them);
lengths are millimetres.  A failing call raises ohm.Error (UsageError for a
bad action, option or value) carrying ohm's one-line message.

Long steps report progress to Context(progress=fn) and stop within about a
second when asked: Ctrl-C during scene.solve() raises KeyboardInterrupt,
Context.cancel() (from another thread, or from fn) makes the running call
raise ohm.Cancelled, and an exception raised in fn or in the log callable
stops the call and reaches its caller.  The scene stays usable either way.
A cancel made while no call runs is aimed at nothing: the next call drops
it and runs.
"""
import ctypes
import sys
import threading
import weakref

import numpy as np

from . import _library

_lib = _library.load()
# the sized structs as this library lays them out (ohm.h's ABI rule)
_GridInfo = _library.struct_type(_lib, "ohm_grid_info")
_ResultInfo = _library.struct_type(_lib, "ohm_result_info")

__all__ = ["Context", "Scene", "Error", "UsageError", "Cancelled", "version"]

OK, ERR_IO, ERR_PARSE, ERR_INVALID, ERR_NOMEM, ERR_USAGE, ERR_NUMERIC, ERR_INTERNAL = 0, -1, -2, -3, -4, -5, -6, -7
ERR_CANCELLED = -8
LOG_WARNING, LOG_INFO = 1, 2


class Error(Exception):
    """A failed ohm call: .code is its OHM_ERR_* status, str() its message."""

    def __init__(self, code, message):
        super().__init__(message)
        self.code = code


class UsageError(Error, ValueError):
    """A bad action, option or value (the command line's exit code 2)."""


class Cancelled(Error):
    """The call was stopped by Context.cancel()."""


def _check(rc):
    if rc != OK:
        message = _lib.ohm_error_last().decode("utf-8", "replace")
        kind = UsageError if rc == ERR_USAGE else Cancelled if rc == ERR_CANCELLED else Error
        raise kind(rc, message)


# An exception raised in a callable ohm calls back (log, progress; and
# KeyboardInterrupt, which Python raises in whatever Python code runs next on
# the main thread, often as the callback is entered) cannot cross the C
# library: ctypes hands it to sys.unraisablehook.  This hook takes the ones
# from a context's callbacks, stops the context's running call, and keeps
# the exception for the call's caller (Context._settle); any other goes to
# the hook that was there before.
_callback_owner = weakref.WeakKeyDictionary()  # trampoline function -> weakref to its Context
_previous_unraisablehook = sys.unraisablehook


def _unraisable(unraisable):
    owner = _callback_owner.get(unraisable.object) if unraisable.object is not None else None
    context = owner() if owner else None
    if context is None or unraisable.exc_value is None:
        _previous_unraisablehook(unraisable)
        return
    context._stop_with(unraisable.exc_value)


sys.unraisablehook = _unraisable


def version():
    """The library's version, "MAJOR.MINOR.PATCH"."""
    return _lib.ohm_version(None, None, None).decode()


def _word(key, value):
    if isinstance(value, bool):
        value = int(value)
    if isinstance(value, (tuple, list, np.ndarray)):
        value = ",".join(repr(float(v)) if not isinstance(v, str) else v for v in value)
    return "%s=%s" % (key, value)


def _words(options):
    """kwargs as a NULL-terminated char*[] (kept alive by the returned list)."""
    encoded = [_word(k, v).encode() for k, v in options.items()]
    array = (ctypes.c_char_p * (len(encoded) + 1))(*encoded, None)
    return array, encoded


class _Handle:
    """An ohm handle's lifetime: close() frees it once (also on leaving a
    with block, and when collected); a closed one refuses to be used."""

    _free = None  # the C function that frees this kind of handle

    def _live(self):
        if not getattr(self, "_handle", None):
            raise Error(ERR_USAGE, "ohm.%s: used after close()" % type(self).__name__)
        return self._handle

    def close(self):
        if getattr(self, "_handle", None):
            type(self)._free(self._handle)
            self._handle = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()


class Context(_Handle):
    """Verbosity (0 warnings only, 1 normal, 2 verbose) and where messages
    and progress go: log(level, text) and progress(what, fraction) are
    called from the thread that called into ohm (a long step calls progress
    at least about ten times a second).  An exception either raises stops
    the call, which then raises it; so does Ctrl-C.  Closing a context
    closes its scenes first."""

    _free = staticmethod(_lib.ohm_context_free)

    def __init__(self, verbosity=1, log=None, progress=None):
        handle = ctypes.c_void_p()
        _check(_lib.ohm_context_new(ctypes.byref(handle)))
        self._handle = handle
        self._log = self._progress = None
        self._pending = None  # the exception a callback raised, for the caller
        self._lock = threading.Lock()
        self._scenes = weakref.WeakSet()
        self.verbosity = verbosity
        self.set_log(log)
        self.set_progress(progress)

    @property
    def verbosity(self):
        return self._verbosity

    @verbosity.setter
    def verbosity(self, value):
        self._verbosity = int(value)
        _lib.ohm_context_set_verbosity(self._live(), self._verbosity)

    def cancel(self):
        """Stop the call running on one of this context's scenes: it raises
        ohm.Cancelled within about a second.  Any thread may call this.
        With no call running it does nothing (the next call drops it)."""
        _lib.ohm_context_cancel(self._live())

    def set_log(self, fn):
        """fn(level, text) for every message; None: on stderr, as ohm: lines."""
        if fn is None:
            self._log = _library.LOG_CALLBACK()
        else:
            def call(_user, level, text):
                fn(level, text.decode("utf-8", "replace"))
            self._log = self._trampoline(_library.LOG_CALLBACK, call)
        _lib.ohm_context_set_log(self._live(), self._log, None)

    def set_progress(self, fn):
        """fn(what, fraction) for every progress report; None: none.  A
        trampoline is installed either way: Ctrl-C takes effect in it."""
        def call(_user, what, fraction):
            if fn is not None:
                fn(what.decode("utf-8", "replace"), fraction)
        self._progress = self._trampoline(_library.PROGRESS_CALLBACK, call)
        _lib.ohm_context_set_progress(self._live(), self._progress, None)

    def poll_progress(self):
        """Keep progress for progress() instead of calling back: no Python
        runs on the solving thread (in Blender, a callback waits for the
        main thread's lock at every report).  set_progress() ends it."""
        _lib.ohm_context_poll_progress(self._live())
        self._progress = None

    def progress(self):
        """The latest progress report of a polling context: (what, fraction).
        Any thread may ask."""
        what = ctypes.create_string_buffer(64)
        fraction = ctypes.c_double()
        _check(_lib.ohm_context_progress(self._live(), what, len(what), ctypes.byref(fraction)))
        return what.value.decode("utf-8", "replace"), fraction.value

    def _trampoline(self, kind, call):
        _callback_owner[call] = weakref.ref(self)
        return kind(call)

    def _stop_with(self, exc):
        with self._lock:
            if self._pending is None:
                self._pending = exc
        if self._handle:
            _lib.ohm_context_cancel(self._handle)

    def _settle(self, rc):
        """A scene call's result: the exception a callback raised, if one
        did (its call stopped), else ohm's error, if any."""
        with self._lock:
            pending, self._pending = self._pending, None
        if pending is not None:
            raise pending
        _check(rc)

    def close(self):
        for scene in list(self._scenes):
            scene.close()
        super().close()


class Scene(_Handle):
    """One object and its light (ohm_scene).  The context must outlive it."""

    _free = staticmethod(_lib.ohm_scene_free)

    def __init__(self, context):
        handle = ctypes.c_void_p()
        _check(_lib.ohm_scene_new(ctypes.byref(handle), context._live()))
        self._handle = handle
        self._context = context  # keeps it (and its callbacks) alive
        context._scenes.add(self)

    # ---- steps ------------------------------------------------------------

    def run(self, action, **options):
        """Run one action with its options: run("voxelize", dim=64)."""
        array, _keep = _words(options)
        self._context._settle(_lib.ohm_scene_run(self._live(), action.encode(), array))

    def run_args(self, words):
        """Run a chain of command-line words: ["-read", "file=a.obj", ...]."""
        encoded = [w.encode() for w in words]
        array = (ctypes.c_char_p * (len(encoded) + 1))(*encoded, None)
        self._context._settle(_lib.ohm_scene_run_args(self._live(), len(encoded), array))

    def run_file(self, path):
        """Run a pipeline file."""
        self._context._settle(_lib.ohm_scene_run_file(self._live(), str(path).encode()))

    def set_mesh(self, vertices, triangles, name=None):
        """A triangle mesh in mm: vertices (n, 3), triangles (m, 3) 0-based."""
        v = np.ascontiguousarray(vertices, dtype=np.float64)
        t = np.ascontiguousarray(triangles, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3 or t.ndim != 2 or t.shape[1] != 3:
            raise UsageError(ERR_USAGE, "ohm.Scene.set_mesh: vertices and triangles must be (n, 3) arrays")
        rc = _lib.ohm_scene_set_mesh(self._live(), v.ctypes.data_as(_library.c_double_p), v.shape[0],
                                     t.ctypes.data_as(_library.c_int64_p), t.shape[0], name.encode() if name else None)
        self._context._settle(rc)

    def set_density(self, values, index_to_world=None, name=None):
        """A density volume indexed [k, j, i] and its voxel-to-world map in
        mm, a (3, 4) matrix at voxel centres (None: 1 mm voxels at 0).
        run("voxelize", threshold=T) then makes the object from it: the
        cells between its outermost voxel centres whose value is >= T."""
        a = np.ascontiguousarray(values, dtype=np.float32)
        if a.ndim != 3:
            raise UsageError(ERR_USAGE, "ohm.Scene.set_density: values must be a 3-D array [k, j, i]")
        m = np.eye(3, 4) if index_to_world is None else np.asarray(index_to_world, dtype=np.float64)
        if m.shape != (3, 4):
            raise UsageError(ERR_USAGE, "ohm.Scene.set_density: index_to_world must be 3 x 4")
        m = np.ascontiguousarray(m)
        dims = (ctypes.c_int64 * 3)(a.shape[2], a.shape[1], a.shape[0])
        rc = _lib.ohm_scene_set_density(self._live(), a.ctypes.data_as(_library.c_float_p), dims,
                                        m.ctypes.data_as(_library.c_double_p), name.encode() if name else None)
        self._context._settle(rc)

    def add_light(self, **options):
        """Add a light: add_light(type="point", pos=(0, 80, 0), intensity=1000), or the sky all
        around: add_light(type="environment", intensity=1e-3) (radiance, W/mm^2/sr), with
        sky="studio.hdr" an equirectangular image (docs/lights.md)."""
        array, _keep = _words(options)
        self._context._settle(_lib.ohm_scene_add_light(self._live(), array))

    def clear_lights(self):
        _check(_lib.ohm_scene_clear_lights(self._live()))

    def solve(self, **options):
        """Solve the lights (solver=auto unless told), keeping the solver's setup for relight() (keep=0 does not)."""
        array, _keep = _words(options)
        self._context._settle(_lib.ohm_scene_solve(self._live(), array))

    def relight(self):
        """Solve the current lights with the last solve's solver, set up once."""
        self._context._settle(_lib.ohm_scene_relight(self._live()))

    # ---- results ----------------------------------------------------------

    @property
    def grid(self):
        """dims (nx, ny, nz), origin (mm, centre of cell 0), voxel (mm), cells, interior_cells."""
        g = _library.sized(_GridInfo)
        _check(_lib.ohm_scene_grid(ctypes.byref(g), self._live()))
        return {"dims": tuple(g.dims), "origin": tuple(g.origin), "voxel": g.voxel, "cells": g.cells,
                "interior_cells": g.interior_cells}

    def estimate(self, **options):
        """What a solve of the scene's mesh would take at dim= cells across, predicted before anything is
        built: interior_cells, grid_cells, bytes_direct/cg/amg/mg/auto (the process's peak), bytes_allowed,
        margin, largest_dim (with solver=, or auto's choice), largest_dim_mg, solver (auto: its choice) and
        reason.  Options as ohm_scene_estimate's: dim= (required), solver=, channels=, solves=, max_memory=."""
        # 1.2's: declared here, not at import, so the package reads a 1.1 library (RuntimeError here)
        estimate = _library.later_function(_lib, "ohm_scene_estimate")
        e = _library.sized(_library.struct_type(_lib, "ohm_estimate_info"))
        array, _keep = _words(options)
        _check(estimate(ctypes.byref(e), self._live(), array))
        return _library.fields_of(e)

    def _shape(self):
        nx, ny, nz = self.grid["dims"]
        return (nz, ny, nx)

    def inside(self):
        """The object's cells, a bool array [k, j, i]."""
        out = np.zeros(self._shape(), dtype=np.uint8)
        _check(_lib.ohm_scene_inside(out.ctypes.data_as(ctypes.POINTER(ctypes.c_uint8)), out.size, self._live()))
        return out.astype(bool)

    def result(self):
        """The latest solve's figures: channels, frames, unknowns, factorizations, solves, residual,
        power_incident/entered/in/absorbed/out (W), seconds_setup, seconds_solve."""
        r = _library.sized(_ResultInfo)
        _check(_lib.ohm_scene_result(ctypes.byref(r), self._live()))
        return _library.fields_of(r)

    def _cells(self, fn, channel, frame):
        out = np.zeros(self._shape(), dtype=np.float64)
        _check(fn(out.ctypes.data_as(_library.c_double_p), out.size, self._live(), int(channel), int(frame)))
        return out

    def fluence(self, channel=0, frame=0):
        """The fluence rate (W/mm^2) per cell [k, j, i], 0 outside."""
        return self._cells(_lib.ohm_scene_fluence, channel, frame)

    def exitance(self, channel=0, frame=0):
        """The exitance (W/mm^2) leaving each cell's boundary faces [k, j, i]."""
        return self._cells(_lib.ohm_scene_exitance, channel, frame)

    def vertex_exitance(self, frame=0):
        """Exitance at each mesh vertex, (vertices, channels) float32."""
        channels = self.result()["channels"]
        vertices = int(self.stat("mesh_vertices"))
        out = np.zeros((vertices, channels), dtype=np.float32)
        _check(_lib.ohm_scene_vertex_exitance(out.ctypes.data_as(_library.c_float_p), out.size, self._live(),
                                              int(frame)))
        return out

    def stat(self, key):
        """A figure of the statistics (the keys -stats writes): a float or a str."""
        number = ctypes.c_double()
        rc = _lib.ohm_scene_stat(ctypes.byref(number), self._live(), key.encode())
        if rc == OK:
            return number.value
        text = ctypes.c_char_p()
        if _lib.ohm_scene_stat_text(ctypes.byref(text), self._live(), key.encode()) == OK:
            return text.value.decode()
        _check(rc)
