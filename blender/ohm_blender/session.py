"""One object's ohm scene, kept between operator calls: the factor lives
here, so Live relight and Bake solve new lights without factoring again,
and only a change of geometry or material sets up anew.

Blender's operators are stateless, so the sessions are kept in this module
by object name; the add-on's unregister closes them all."""
import time

import numpy as np

from . import bridge

try:  # the package bundled into the add-on's zip (lib/libohm.so.1 beside it)
    from . import ohm as ohmlib
except ImportError:  # running from a source tree with ohm on sys.path
    import ohm as ohmlib

_sessions = {}


def get(obj):
    return _sessions.get(obj.name)


def get_or_create(obj):
    s = _sessions.get(obj.name)
    if s is None:
        s = _sessions[obj.name] = Session()
    return s


def close_all():
    for s in _sessions.values():
        s.close()
    _sessions.clear()


def _settings_signature(obj, bscene):
    st = obj.ohm
    m = tuple(tuple(r) for r in obj.matrix_world)
    me = obj.data
    co = np.empty(3 * len(me.vertices))
    me.vertices.foreach_get("co", co)
    return (m, len(me.vertices), len(me.polygons), float(co.sum()), float(np.abs(co).sum()),
            bscene.unit_settings.scale_length, st.material, st.preset, tuple(st.sigma_a), tuple(st.sigma_s), st.eta,
            st.volume_path, st.transfer_path, st.grid, st.dim, st.error, st.boundary, st.solver, st.shadows)


class Session:
    def __init__(self, progress=None):
        self.messages = []
        self.ctx = ohmlib.Context(verbosity=1, log=self._log, progress=progress)
        self.scene = None
        self.geometry = None      # settings signature the factor was made for
        self.lights = None        # lights signature of the current solution
        self.last = {}            # the latest update's timings (s)
        self.setups = 0
        self.relights = 0

    def _log(self, level, text):
        self.messages.append(("WARNING" if level == ohmlib.LOG_WARNING else "INFO", text))
        del self.messages[:-200]

    def close(self):
        if self.scene is not None:
            self.scene.close()
            self.scene = None
        self.ctx.close()

    # ---- the two kinds of update -------------------------------------------

    def setup(self, obj, bscene):
        """Voxelize the object as placed, set its material and the scene's
        lights, factor and solve: the factor is kept."""
        st = obj.ohm
        mm = bridge.mm_per_unit(bscene)
        lights = bridge.scene_lights(bscene, mm)
        if not lights:
            raise ohmlib.UsageError(ohmlib.ERR_USAGE, "the scene has no point, sun, spot or area light")
        if self.scene is not None:
            self.scene.close()
        t0 = time.perf_counter()
        sc = self.scene = ohmlib.Scene(self.ctx)
        verts, tris = bridge.mesh_arrays(obj, mm)
        sc.set_mesh(verts, tris, name=obj.name)
        if st.material == "PRESET":
            sc.run("material", preset=st.preset)
        elif st.material == "COEFFICIENTS":
            sc.run("material", sigma_a=tuple(st.sigma_a), sigma_s=tuple(st.sigma_s), eta=st.eta)
        else:
            import bpy
            sc.run("read", file=bpy.path.abspath(st.volume_path))
            sc.run("place")
            sc.run("material", transfer=bpy.path.abspath(st.transfer_path))
        for opts in lights:
            sc.add_light(**opts)
        if st.grid == "DIM":
            sc.run("voxelize", dim=st.dim)
        else:
            sc.run("voxelize", error=st.error)
        sc.solve(boundary=st.boundary, solver=st.solver, shadows="mesh" if st.shadows else "none")
        self.geometry = _settings_signature(obj, bscene)
        self.lights = bridge.lights_signature(bscene)
        self.setups += 1
        self.last = {"setup": time.perf_counter() - t0}
        self._write(obj)
        return self.last

    def relight(self, obj, bscene):
        """The scene's lights as they are now, solved with the kept factor."""
        mm = bridge.mm_per_unit(bscene)
        lights = bridge.scene_lights(bscene, mm)
        if not lights:
            raise ohmlib.UsageError(ohmlib.ERR_USAGE, "the scene has no point, sun, spot or area light")
        sc = self.scene
        t_source0, t_solve0 = sc.stat("t_source"), sc.stat("t_solve")
        t0 = time.perf_counter()
        sc.clear_lights()
        for opts in lights:
            sc.add_light(**opts)
        sc.relight()
        t1 = time.perf_counter()
        self.lights = bridge.lights_signature(bscene)
        self.relights += 1
        self.last = {"source_and_shadows": sc.stat("t_source") - t_source0, "solve": sc.stat("t_solve") - t_solve0,
                     "relight_call": t1 - t0}
        self._write(obj)
        self.last["total"] = time.perf_counter() - t0
        return self.last

    def update(self, obj, bscene):
        """What changed since the last solve: 'setup' (geometry or material:
        a new factor), 'relight' (lights only), or None."""
        if self.scene is None or _settings_signature(obj, bscene) != self.geometry:
            self.setup(obj, bscene)
            return "setup"
        if bridge.lights_signature(bscene) != self.lights:
            self.relight(obj, bscene)
            return "relight"
        return None

    def recolour(self, obj):
        """The colour attribute again from the current solution (after a
        change of exposure or attribute name: no solve)."""
        self._write(obj)

    def _write(self, obj):
        t0 = time.perf_counter()
        exitance = self.scene.vertex_exitance()
        t1 = time.perf_counter()
        self.exposure = bridge.write_colours(obj, obj.ohm.attribute, exitance, obj.ohm.exposure)
        t2 = time.perf_counter()
        self.last["vertex_exitance"] = t1 - t0
        self.last["attribute_write"] = t2 - t1
        r = self.scene.result()
        obj.ohm.factorizations = r["factorizations"]
        self.result = r
