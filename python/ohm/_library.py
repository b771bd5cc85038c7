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


class _Field(ctypes.Structure):
    """ohm.h's ohm_struct_member: one member of a sized struct as the library lays it out."""
    _fields_ = [("name", ctypes.c_char_p), ("offset", ctypes.c_size_t), ("type", ctypes.c_int), ("count", ctypes.c_int)]


# ohm.h's ohm_member_type -> the ctypes type of one element
_FIELD_TYPES = {1: ctypes.c_size_t, 2: ctypes.c_int, 3: ctypes.c_int32, 4: ctypes.c_int64, 5: ctypes.c_double,
                6: ctypes.c_char}  # 6: a NUL-terminated text of `count` bytes (1.2)


def struct_type(lib, name):
    """The ctypes struct of ohm.h's sized struct `name`, laid out as the
    loaded library says (ohm_struct_members): its fields, a later 1.x's new
    ones too, at the library's offsets, padded to the library's size.  Make
    one with sized()."""
    count, size = ctypes.c_size_t(), ctypes.c_size_t()
    fields = lib.ohm_struct_members(name.encode(), ctypes.byref(count), ctypes.byref(size))
    if not fields:
        raise RuntimeError(lib.ohm_error_last().decode(errors="replace"))
    members, pos = [], 0
    for k in range(count.value):
        f = fields[k]
        if f.type not in _FIELD_TYPES:
            raise RuntimeError(f"ohm_struct_members({name}): field {f.name!r} has a type this package does not know ({f.type})")
        kind = _FIELD_TYPES[f.type] * f.count if f.count > 1 else _FIELD_TYPES[f.type]
        if f.offset > pos:
            members.append((f"_pad{k}", ctypes.c_char * (f.offset - pos)))
        members.append((f.name.decode(), kind))
        pos = f.offset + ctypes.sizeof(kind)
    if size.value > pos:
        members.append(("_pad_end", ctypes.c_char * (size.value - pos)))
    made = type(name, (ctypes.Structure,), {"_fields_": members})
    if ctypes.sizeof(made) != size.value:
        raise RuntimeError(f"ohm_struct_members({name}): {ctypes.sizeof(made)} bytes laid out, the library says {size.value}")
    return made


def fields_of(struct):
    """A sized struct's members by name, without its size and padding; texts as str."""
    out = {name: getattr(struct, name) for name, _ in struct._fields_ if name != "size" and not name.startswith("_pad")}
    return {k: v.decode(errors="replace") if isinstance(v, bytes) else v for k, v in out.items()}


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
        "ohm_context_poll_progress": (None, [vp]),
        "ohm_context_progress": (i, [vp, ctypes.c_char_p, ctypes.c_size_t, ctypes.POINTER(ctypes.c_double)]),
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
        "ohm_struct_members": (ctypes.POINTER(_Field), [ctypes.c_char_p, ctypes.POINTER(sz), ctypes.POINTER(sz)]),
        "ohm_scene_grid": (i, [vp, vp]),
        "ohm_scene_inside": (i, [ctypes.POINTER(ctypes.c_uint8), sz, vp]),
        "ohm_scene_result": (i, [vp, vp]),
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


# Functions of a later 1.x than the oldest library the package reads: each
# is declared when first called, so that `import ohm` works against an older
# 1.x library and only the call that needs the newer one fails.
_LATER = {
    "ohm_scene_estimate": ("1.2", ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p, c_char_pp]),
}


def later_function(lib, name):
    """ohm.h's function `name` of a later 1.x (_LATER), declared; an older
    library: RuntimeError naming the version found and the one needed."""
    since, res, args = _LATER[name]
    fn = getattr(lib, name, None)
    if fn is None:
        found = lib.ohm_version(None, None, None).decode()
        raise RuntimeError(f"ohm: {name} needs libohm {since} or later; the library loaded is {found}")
    fn.restype = res
    fn.argtypes = args
    return fn
