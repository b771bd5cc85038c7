"""bpy.ops.ohm.solve, bpy.ops.ohm.live, bpy.ops.ohm.bake."""
import os
import time

import bpy

from . import bridge, session

try:
    from . import ohm as ohmlib
except ImportError:
    import ohm as ohmlib


def _mesh_poll(context):
    obj = context.active_object
    return obj is not None and obj.type == "MESH"


def _progress_reporter(wm):
    """ohm's progress (what, fraction) as Blender's progress cursor."""
    state = {"open": False}

    def report(what, fraction):
        if not state["open"]:
            wm.progress_begin(0, 100)
            state["open"] = True
        wm.progress_update(int(100 * fraction))
        if fraction >= 1:
            wm.progress_end()
            state["open"] = False
    return report


def _report_failure(op, obj, e):
    obj.ohm.status = str(e)
    op.report({"ERROR"}, "ohm: %s" % e)
    return {"CANCELLED"}


def _volume_material(name, exposure):
    """An emitting volume: the fluence grids as emission colour (W/mm^2 x
    exposure), the density grid for a faint absorption."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    vol = nt.nodes.new("ShaderNodeVolumePrincipled")
    combine = nt.nodes.new("ShaderNodeCombineRGB") if bpy.app.version < (3, 3, 0) else nt.nodes.new("ShaderNodeCombineColor")
    for i, ch in enumerate("rgb"):
        a = nt.nodes.new("ShaderNodeAttribute")
        a.attribute_name = "fluence_" + ch
        nt.links.new(a.outputs["Fac"], combine.inputs[i])
    nt.links.new(combine.outputs[0], vol.inputs["Emission Color"])
    vol.inputs["Emission Strength"].default_value = exposure
    vol.inputs["Density"].default_value = 0.0
    nt.links.new(vol.outputs[0], out.inputs["Volume"])
    return mat


def add_volume(context, obj, s, path):
    """The solution as a volume object over the mesh: ohm writes world
    millimetres with voxel centres at index points, Blender draws voxel
    (i, j, k) over [i, i+1]: scaled to scene units and moved back half a voxel."""
    s.scene.run("write", file=path)
    bpy.ops.object.volume_import(filepath=path, align="WORLD", location=(0, 0, 0))
    vobj = context.active_object
    mm = bridge.mm_per_unit(context.scene)
    h = s.scene.grid["voxel"]
    vobj.scale = (1.0 / mm,) * 3
    vobj.location = (-0.5 * h / mm,) * 3
    vobj.name = obj.name + "_ohm"
    vobj.data.materials.append(_volume_material(obj.name + "_ohm", s.exposure))
    context.view_layer.objects.active = obj
    return vobj


class OHM_OT_solve(bpy.types.Operator):
    """Voxelize the object as placed, solve subsurface scattering for the scene's lights, and write the exitance
    onto the mesh as a colour attribute (the factor is kept for Live relight and Bake)"""
    bl_idname = "ohm.solve"
    bl_label = "Solve"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return _mesh_poll(context)

    def execute(self, context):
        obj = context.active_object
        s = session.get_or_create(obj)
        s.ctx.set_progress(_progress_reporter(context.window_manager))
        try:
            t = s.setup(obj, context.scene)
            if obj.ohm.make_volume:
                d = bpy.path.abspath(obj.ohm.directory)
                os.makedirs(d, exist_ok=True)
                add_volume(context, obj, s, os.path.join(d, obj.name + ".vdb"))
        except (ohmlib.Error, OSError, RuntimeError) as e:
            return _report_failure(self, obj, e)
        r = s.result
        obj.ohm.status = "%d cells, %d factorizations, %.2f s; power out %.4g W" % (
            r["unknowns"], r["factorizations"], t["setup"], r["power_out"])
        self.report({"INFO"}, "ohm: " + obj.ohm.status)
        return {"FINISHED"}


def live_step(context, obj):
    """One tick of Live relight, as its timer runs it: a changed light is
    relit from the kept factor, a changed geometry or material refactors.
    Returns what happened ('setup', 'relight' or None)."""
    s = session.get_or_create(obj)
    what = s.update(obj, context.scene)
    if what:
        for area in context.screen.areas if context.screen else ():
            if area.type == "VIEW_3D":
                area.tag_redraw()
    return what


class OHM_OT_live(bpy.types.Operator):
    """Relight live: moving, rotating or recolouring a light re-solves from the kept factor and updates the colour
    attribute; a change of geometry or material refactors once.  Esc or right-click stops"""
    bl_idname = "ohm.live"
    bl_label = "Live relight"

    _timer = None

    @classmethod
    def poll(cls, context):
        return _mesh_poll(context)

    def invoke(self, context, event):
        self.obj = context.active_object
        try:
            live_step(context, self.obj)
        except ohmlib.Error as e:
            return _report_failure(self, self.obj, e)
        self.updates, self.t0 = 0, time.perf_counter()
        self._timer = context.window_manager.event_timer_add(1.0 / 60.0, window=context.window)
        context.window_manager.modal_handler_add(self)
        self.obj.ohm.status = "live: move a light (Esc to stop)"
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type in {"ESC", "RIGHTMOUSE"}:
            return self.cancel(context) or {"CANCELLED"}
        if event.type == "TIMER":
            try:
                if live_step(context, self.obj):
                    self.updates += 1
            except ohmlib.Error as e:
                self.cancel(context)
                return _report_failure(self, self.obj, e)
            elapsed = time.perf_counter() - self.t0
            if elapsed >= 1.0:
                self.obj.ohm.updates_per_second = self.updates / elapsed
                self.updates, self.t0 = 0, time.perf_counter()
        return {"PASS_THROUGH"}

    def cancel(self, context):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None
        self.obj.ohm.status = "live relight stopped"


class OHM_OT_bake(bpy.types.Operator):
    """Bake the lights' animation over the frame range: a .vdb sequence and a colour attribute per frame, one
    factor for all frames"""
    bl_idname = "ohm.bake"
    bl_label = "Bake sequence"

    @classmethod
    def poll(cls, context):
        return _mesh_poll(context)

    def execute(self, context):
        obj, sc = context.active_object, context.scene
        d = bpy.path.abspath(obj.ohm.directory)
        os.makedirs(d, exist_ok=True)
        s = session.get_or_create(obj)
        wm = context.window_manager
        frames = range(sc.frame_start, sc.frame_end + 1)
        wm.progress_begin(0, len(frames))
        keep = sc.frame_current
        try:
            for n, f in enumerate(frames):
                sc.frame_set(f)
                s.update(obj, sc)
                s.scene.run("write", file=os.path.join(d, "%s_%04d.vdb" % (obj.name, f)))
                exitance = s.scene.vertex_exitance()
                bridge.write_colours(obj, "%s_%04d" % (obj.ohm.attribute, f), exitance, obj.ohm.exposure)
                wm.progress_update(n + 1)
        except (ohmlib.Error, OSError) as e:
            return _report_failure(self, obj, e)
        finally:
            wm.progress_end()
            sc.frame_set(keep)
        obj.ohm.status = "baked frames %d-%d, %d factorizations" % (frames[0], frames[-1], obj.ohm.factorizations)
        self.report({"INFO"}, "ohm: " + obj.ohm.status)
        return {"FINISHED"}


classes = (OHM_OT_solve, OHM_OT_live, OHM_OT_bake)
