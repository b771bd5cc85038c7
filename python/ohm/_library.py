"""Finding and declaring libohm (include/ohm.h) for ctypes.

The library is looked for, in order: $OHM_LIBRARY (a path); the path the
build or the install recorded in _location.py, relative to this package or
absolute; the system's (ctypes.util.find_library("ohm")).
"""
import ctypes
import ctypes.util
import os

_here = os.path.dirname(os.path.abspath(__file__))


def _candidates():
    env = os.environ.get("OHM_LIBRARY")
    if env:
        yield env
    try:
        from . import _location
        path = _location.LIBRARY
        yield path if os.path.isabs(path) else os.path.normpath(os.path.join(_here, path))
    except ImportError:
        pass
    found = ctypes.util.find_library("ohm")
    if found:
        yield found


def load():
    tried = []
    for path in _candidates():
        try:
            return _declare(ctypes.CDLL(path))
        except OSError as e:
            tried.append("%s (%s)" % (path, e))
    raise ImportError("ohm: libohm not found; tried: %s; set OHM_LIBRARY to its path"
                      % ("; ".join(tried) or "nothing"))


c_double_p = ctypes.POINTER(ctypes.c_double)
c_float_p = ctypes.POINTER(ctypes.c_float)
c_int64_p = ctypes.POINTER(ctypes.c_int64)
c_char_pp = ctypes.POINTER(ctypes.c_char_p)

LOG_CALLBACK = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_int, ctypes.c_char_p)
PROGRESS_CALLBACK = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_char_p, ctypes.c_double)


# The sized structs of ohm.h (its ABI rule): the library fills the fields
# of the size given, so this copy of 1.0's layout stays right against any
# 1.x library, which may know more fields; sized() sets the size.
class GridInfo(ctypes.Structure):
    _fields_ = [("size", ctypes.c_size_t), ("dims", ctypes.c_int32 * 3), ("origin", ctypes.c_double * 3), ("voxel", ctypes.c_double),
                ("cells", ctypes.c_int64), ("interior_cells", ctypes.c_int64)]


class ResultInfo(ctypes.Structure):
    _fields_ = [("size", ctypes.c_size_t), ("channels", ctypes.c_int), ("frames", ctypes.c_int), ("unknowns", ctypes.c_int64),
                ("factorizations", ctypes.c_int), ("solves", ctypes.c_int64), ("residual", ctypes.c_double),
                ("power_incident", ctypes.c_double), ("power_entered", ctypes.c_double),
                ("power_in", ctypes.c_double), ("power_absorbed", ctypes.c_double),
                ("power_out", ctypes.c_double), ("seconds_setup", ctypes.c_double),
                ("seconds_solve", ctypes.c_double)]


def sized(kind):
    """A struct of ohm.h's with its size member set (its *_INIT)."""
    return kind(size=ctypes.sizeof(kind))


def _declare(lib):
    """Argument and result types of every function ohm.py calls (ohm.h)."""
    vp, i, sz = ctypes.c_void_p, ctypes.c_int, ctypes.c_size_t
    sigs = {
        "ohm_version": (ctypes.c_char_p, [ctypes.POINTER(i), ctypes.POINTER(i), ctypes.POINTER(i)]),
        "ohm_error_last": (ctypes.c_char_p, []),
        "ohm_error_last_code": (i, []),
        "ohm_context_new": (i, [ctypes.POINTER(vp)]),
        "ohm_context_free": (None, [vp]),
        "ohm_context_set_verbosity": (None, [vp, i]),
        "ohm_context_set_log": (None, [vp, LOG_CALLBACK, vp]),
        "ohm_context_set_progress": (None, [vp, PROGRESS_CALLBACK, vp]),
        "ohm_context_cancel": (None, [vp]),
        "ohm_scene_new": (i, [ctypes.POINTER(vp), vp]),
        "ohm_scene_free": (None, [vp]),
        "ohm_scene_run": (i, [vp, ctypes.c_char_p, c_char_pp]),
        "ohm_scene_run_args": (i, [vp, i, c_char_pp]),
        "ohm_scene_run_file": (i, [vp, ctypes.c_char_p]),
        "ohm_scene_set_mesh": (i, [vp, c_double_p, sz, c_int64_p, sz, ctypes.c_char_p]),
        "ohm_scene_set_density": (i, [vp, c_float_p, c_int64_p, c_double_p, ctypes.c_char_p]),
        "ohm_scene_add_light": (i, [vp, c_char_pp]),
        "ohm_scene_clear_lights": (i, [vp]),
        "ohm_scene_solve": (i, [vp, c_char_pp]),
        "ohm_scene_relight": (i, [vp]),
        "ohm_scene_grid": (i, [ctypes.POINTER(GridInfo), vp]),
        "ohm_scene_inside": (i, [ctypes.POINTER(ctypes.c_uint8), sz, vp]),
        "ohm_scene_result": (i, [ctypes.POINTER(ResultInfo), vp]),
        "ohm_scene_fluence": (i, [c_double_p, sz, vp, i, i]),
        "ohm_scene_exitance": (i, [c_double_p, sz, vp, i, i]),
        "ohm_scene_vertex_exitance": (i, [c_float_p, sz, vp, i]),
        "ohm_scene_stat": (i, [c_double_p, vp, ctypes.c_char_p]),
        "ohm_scene_stat_text": (i, [ctypes.POINTER(ctypes.c_char_p), vp, ctypes.c_char_p]),
    }
    for name, (res, args) in sigs.items():
        fn = getattr(lib, name)
        fn.restype = res
        fn.argtypes = args
    return lib
