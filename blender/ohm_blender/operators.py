"""bpy.ops.ohm.solve, bpy.ops.ohm.cancel, bpy.ops.ohm.live, bpy.ops.ohm.bake,
bpy.ops.ohm.remove.

Solve and Live relight's first setup run off Blender's UI thread when
invoked from the interface (a session.Job polled by a modal timer): the
window stays responsive, the status bar, the cursor and the panel follow the
library's progress, and Esc or the panel's Cancel stops the solve within
about a second.  Called from a script (execute) they run on the caller's
thread.  Every failure and warning of a run becomes a Blender report (the
status bar and the Info editor), worded for the artist (messages.py), and
stays in the panel until the next run; the library's own text goes to the
console."""
import glob
import os
import re
import shutil
import tempfile
import time

import bpy
import numpy as np

from . import bridge, messages, session

try:
    from . import ohm as ohmlib
except ImportError:
    import ohm as ohmlib

# At most this many of a run's warnings become reports (the panel shows them all).
MAX_REPORTED_WARNINGS = 8
# The modal timer's period while a job runs.  Each tick redraws only the
# panel, and only when its status changed: redrawing the 3D views ten times a
# second took the CPU from the solve (under Xvfb a 4.3 s setup took 23 s).
JOB_TICK_S = 0.1
# Live relight's timer: how often it looks for a moved light.
LIVE_TICK_S = 1.0 / 60.0


def _mesh_poll(context):
    obj = context.active_object
    return obj is not None and obj.type == "MESH"


def _running(context):
    """The active object's running job, or None."""
    s = session.get(context.active_object) if _mesh_poll(context) else None
    return s.job if s is not None else None


def _idle_mesh_poll(context):
    """A mesh whose session runs nothing: Solve, Live and Bake may start."""
    return _mesh_poll(context) and _running(context) is None


def _redraw(context, kinds=("PROPERTIES", "VIEW_3D")):
    for window in context.window_manager.windows:
        for area in window.screen.areas:
            if area.type in kinds:
                area.tag_redraw()


def _status_bar(context, text):
    """Blender's status bar (None: its own again)."""
    if context.workspace is not None:
        context.workspace.status_text_set(text)


def subject(obj, scene, s=None):
    """What messages.py names: the object, its lights, the panel's
    settings (only the session's name when the object is gone)."""
    try:
        st = obj.ohm
        mm = bridge.mm_per_unit(scene, obj)
        try:
            lights = list(zip(bridge.light_names(scene), (o["type"] for o in bridge.scene_lights(scene, mm))))
        except ohmlib.Error:  # a sky image ohm cannot read: said by the failure itself
            lights = []
        material = st.preset if st.material == "PRESET" else "this material"
        return messages.Subject(obj.name, lights, st.dim, st.error, st.grid, st.max_memory, material, mm,
                                st.scale <= 0, max(obj.dimensions))
    except ReferenceError:
        return messages.Subject(s.name if s is not None else "the object")


def _report_notes(op, s, notes):
    """Notes as Blender reports (at most MAX_REPORTED_WARNINGS) and in the
    panel; the library's own words on the console."""
    s.notes = list(notes)
    s.warnings = [n.text for n in s.notes]
    for note in s.notes[:MAX_REPORTED_WARNINGS]:
        op.report({note.level}, "ohm: " + note.text)
        if note.raw:
            print("ohm: %s: %s" % (note.level.lower(), note.raw.replace("\n", "\nohm: ")))
    if len(s.notes) > MAX_REPORTED_WARNINGS:
        op.report({"WARNING"}, "ohm: %d more messages in the panel" % (len(s.notes) - MAX_REPORTED_WARNINGS))


def _report_warnings(op, s, obj=None, scene=None):
    """The run's ohm warnings, as Blender reports and in the panel."""
    obj = obj if obj is not None else getattr(op, "obj", None) or bpy.context.active_object
    scene = scene if scene is not None else bpy.context.scene
    notes = messages.warnings(s.run_warnings(), subject(obj, scene, s))
    exposure = _exposure_note(s)
    _report_notes(op, s, notes + ([exposure] if exposure else []))


def _report_failure(op, s, e, obj=None):
    """A failed run: its headline as the status and an ERROR report (a
    cancel a WARNING), after the run's warnings."""
    obj = obj if obj is not None else getattr(op, "obj", None) or bpy.context.active_object
    about = subject(obj, bpy.context.scene, s)
    failed = messages.failure(e, about)
    notes = messages.warnings(s.run_warnings(), about)
    if failed.kind == "dark":  # the failure names every light; the warnings' per-light notes say it again
        notes = [n for n in notes if n.kind != "dark"]
    s.status = failed.text
    _report_notes(op, s, [failed] + notes)
    return {"CANCELLED"}


def _exposure_note(s):
    """A WARNING when the kept automatic exposure shows the result far too
    dark or bright (a new material, Scale or light since it was chosen)."""
    if s.scene is None or s.exposure is None:
        return None
    lit = s.mesh_exitance()
    lit = lit[lit > 0]
    if not lit.size:
        return None
    shown = float(np.percentile(lit, 99)) * s.exposure
    if 0.02 <= shown <= 50.0:
        return None
    return messages.Note("WARNING", "The result is %.3g× %s than Exposure was chosen for: press Auto exposure" % (
        1 / shown if shown < 1 else shown, "darker" if shown < 1 else "brighter"), kind="exposure")


def output_directory(obj):
    """The panel's output folder as an absolute path: a '//' folder of an
    unsaved file (which has no folder of its own) goes to the temporary
    folder, and the panel shows where."""
    d = obj.ohm.directory
    if d.startswith("//") and not bpy.data.filepath:
        return os.path.join(tempfile.gettempdir(), "ohm", d[2:])
    return os.path.abspath(bpy.path.abspath(d))


def add_volume(context, obj, s, path, frames=None, exposure=None):
    """The solution as a volume object over the mesh, from the .vdb at path
    (written already): ohm writes world millimetres with voxel centres at
    index points, Blender draws voxel (i, j, k) over [i, i+1]: scaled to
    scene units and moved back half a voxel.  frames: a bake's (first,
    count), its files NAME_FFFF.vdb one per frame: Blender's sequence
    volume loads frame f's file at scene frame f (frame_offset makes the
    number in the name the scene's frame) and holds the first and last
    beyond the range, as the surface does.  exposure: the emission's
    (default: the session's last)."""
    old = bpy.data.objects.get(bridge.volume_name(obj))
    if old is not None and old.type == "VOLUME":  # the last Solve's or Bake's: replaced
        bridge.remove_volume(old)
    volume = bpy.data.volumes.new(bridge.volume_name(obj))
    volume.filepath = path
    if bpy.data.filepath:  # relative to a saved file: the folder may move with it
        try:
            volume.filepath = bpy.path.relpath(path)
        except ValueError:  # (another drive)
            pass
    if frames is not None:
        volume.is_sequence = True
        volume.frame_start, volume.frame_duration = frames
        volume.frame_offset = frames[0] - 1
        volume.sequence_mode = "EXTEND"
    vobj = bpy.data.objects.new(bridge.volume_name(obj), volume)
    (obj.users_collection[0] if obj.users_collection else context.scene.collection).objects.link(vobj)
    mm = s.mm_per_unit
    h = s.scene.grid["voxel"]
    vobj.scale = (1.0 / mm,) * 3
    vobj.location = (-0.5 * h / mm,) * 3
    channels = int(s.scene.stat("channels"))
    sfx = ("_r", "_g", "_b") if channels == 3 else ("",)
    uniform = None if s.scene.stat("medium_varies") else \
        {name + x: s.scene.stat(name + x) for name in ("sigma_a", "sigma_s") for x in sfx}
    volume.materials.append(bridge.volume_material(bridge.volume_name(obj), channels, uniform, mm,
                                                   s.exposure if exposure is None else exposure))
    return vobj


def _show(obj):
    """A Solve's or Live's result shown in the object's materials (a bake's
    frames give way to it)."""
    bridge.drop_frames(obj)
    if obj.ohm.show_result:
        bridge.show_result(obj, obj.ohm.attribute)


def _after_setup(context, obj, s):
    """What Solve adds to a finished setup: its result shown, the volume object."""
    _show(obj)
    if obj.ohm.make_volume:
        d = output_directory(obj)
        os.makedirs(d, exist_ok=True)
        path = os.path.join(d, obj.name + ".vdb")
        s.scene.run("write", file=path)
        add_volume(context, obj, s, path)


def _summary(s, seconds):
    r = s.result
    return "%d cells solved in %.2f s (%s); %.3g W of light leaves the object" % (
        r["unknowns"], seconds, s.solver or "solved", r["power_out"])


class _Background:
    """Jobs (session.Job) polled by a modal operator's timer."""

    _timer = None
    _handling = False

    def attach(self, context, period):
        """The operator's timer and modal handler, once each."""
        wm = context.window_manager
        if self._timer is None:
            self._timer = wm.event_timer_add(period, window=context.window)
        if not self._handling:
            wm.modal_handler_add(self)
            self._handling = True

    def detach(self, context):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None

    def start(self, context, obj, s, period=JOB_TICK_S):
        """A setup of obj on a job, with progress."""
        s.begin_run()
        job = s.gather(obj, context.scene, context.evaluated_depsgraph_get())
        self.obj, self.session = obj, s
        self.job = session.Job(s, job)
        context.window_manager.progress_begin(0, 1000)
        self.attach(context, period)
        s.status = "setting up (Esc to cancel)"

    def poll_job(self, context, event):
        """None while the job runs; else the job, ended.  Esc cancels it."""
        s = self.session
        if event.type == "ESC" and event.value == "PRESS":
            self.job.cancel()
            s.status = "cancelling"
        if event.type != "TIMER":
            return None
        setup = self.job.kind == "setup"
        if setup:
            what, fraction = s.progress
            context.window_manager.progress_update(int(1000 * min(1.0, max(0.0, fraction))))
            if what:
                status = "%s: %d%% (Esc to cancel)" % (what, round(100 * fraction))
                if status != s.status:  # only the panel redraws, and only for news
                    s.status = status
                    _status_bar(context, "ohm: " + status)
                    _redraw(context, ("PROPERTIES",))
        if not self.job.done():
            return None
        job, self.job = self.job, None
        job.end()
        if setup:
            context.window_manager.progress_end()
            _status_bar(context, None)
        return job

    def stop_job(self, context):
        """Cancel a running job and wait for it (about a second at most)."""
        if getattr(self, "job", None) is not None:
            job, self.job = self.job, None
            job.cancel()
            job.end()
            if job.kind == "setup":
                context.window_manager.progress_end()
                _status_bar(context, None)


class OHM_OT_solve(bpy.types.Operator, _Background):
    """Voxelize the object as shown (modifiers applied), solve subsurface scattering for the scene's lights, and
    write the exitance onto the mesh as a colour attribute (the solver is kept for Live relight and Bake).  Runs in
    the background: Esc cancels"""
    bl_idname = "ohm.solve"
    bl_label = "Solve"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return _idle_mesh_poll(context)

    def execute(self, context):
        obj = self.obj = context.active_object
        s = session.get_or_create(obj)
        s.begin_run()
        try:
            t = s.setup(obj, context.scene, context.evaluated_depsgraph_get())
            _after_setup(context, obj, s)
        except (ohmlib.Error, OSError, RuntimeError) as e:
            return _report_failure(self, s, e)
        return self._done(s, t["setup"])

    def invoke(self, context, event):
        obj = self.obj = context.active_object
        s = session.get_or_create(obj)
        try:
            self.start(context, obj, s)
        except (ohmlib.Error, OSError, RuntimeError) as e:
            return _report_failure(self, s, e)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        job = self.poll_job(context, event)
        if job is None:
            return {"PASS_THROUGH"}
        self.detach(context)
        s = self.session
        if job.error is not None:
            return _report_failure(self, s, job.error)
        try:
            t = s.finish(self.obj, job.job)
            _after_setup(context, self.obj, s)
        except ReferenceError:  # the object was deleted (or an undo remade it) while it solved
            s.status = "the object was deleted or undone while it solved"
            self.report({"WARNING"}, "ohm: " + s.status)
            return {"CANCELLED"}
        except (ohmlib.Error, OSError, RuntimeError) as e:
            return _report_failure(self, s, e)
        _redraw(context)
        return self._done(s, t["setup"])

    def cancel(self, context):
        self.detach(context)
        self.stop_job(context)

    def _done(self, s, seconds):
        s.status = _summary(s, seconds)
        _report_warnings(self, s)
        self.report({"INFO"}, "ohm: " + s.status)
        return {"FINISHED"}


class OHM_OT_cancel(bpy.types.Operator):
    """Stop the solve running on the active object (within about a second)"""
    bl_idname = "ohm.cancel"
    bl_label = "Cancel"

    @classmethod
    def poll(cls, context):
        return _running(context) is not None

    def execute(self, context):
        s = session.get(context.active_object)
        s.job.cancel()
        s.status = "cancelling"
        return {"FINISHED"}


class OHM_OT_auto_exposure(bpy.types.Operator):
    """Choose the exposure again from the current result (its brightest 1% white) and keep it: Live relight and
    Bake then show the lights' power and colour as they change"""
    bl_idname = "ohm.auto_exposure"
    bl_label = "Auto exposure"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        s = session.get(context.active_object) if _mesh_poll(context) else None
        return s is not None and s.scene is not None and s.job is None

    def execute(self, context):
        obj = context.active_object
        s = session.get(obj)
        exposure = s.choose_exposure()
        obj.ohm.exposure = exposure  # shown and saved; its update recolours
        self.report({"INFO"}, "ohm: Exposure %.4g" % exposure)
        return {"FINISHED"}


def live_step(context, obj):
    """One update of Live relight on this thread, for scripts and tests (the
    operator's timer runs the same session steps in the background): a
    changed light is relit from the kept solver, a changed geometry or
    material sets up again.  Returns what happened ('setup', 'relight' or
    None)."""
    s = session.get_or_create(obj)
    what = s.update(obj, context.scene, context.evaluated_depsgraph_get())
    if what:
        for area in context.screen.areas if context.screen else ():
            if area.type == "VIEW_3D":
                area.tag_redraw()
    return what


class OHM_OT_live(bpy.types.Operator, _Background):
    """Relight live: moving, rotating or recolouring a light re-solves from the kept solver and updates the colour
    attribute; a change of geometry or material sets up again.  Both run in the background, so the window stays
    responsive.  Esc or right-click stops"""
    bl_idname = "ohm.live"
    bl_label = "Live relight"

    @classmethod
    def poll(cls, context):
        return _idle_mesh_poll(context)

    def invoke(self, context, event):
        self.obj = context.active_object
        self.session = session.get_or_create(self.obj)
        self.job = None
        bridge.drop_frames(self.obj)  # Live shows its own result, not a bake's frames
        self.updates, self.t0 = 0, time.perf_counter()
        self.attach(context, LIVE_TICK_S)
        self._live_status()
        return {"RUNNING_MODAL"}

    def _live_status(self):
        s = self.session
        rate = " %.1f updates/s," % s.updates_per_second if s.updates_per_second > 0 else ""
        s.status = "live (%s):%s move a light; Esc stops" % (s.solver or "solver", rate)

    def modal(self, context, event):
        s = self.session
        try:
            self.obj.name  # noqa: B018  (the object may have been deleted)
        except ReferenceError:
            self.cancel(context)
            return {"CANCELLED"}
        if event.type in {"ESC", "RIGHTMOUSE"} and event.value == "PRESS":
            self.cancel(context)
            s.status = "live relight stopped"
            _redraw(context, ("PROPERTIES",))
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            if self.job is not None:  # a setup or a relight, in the background
                job = self.poll_job(context, event)
                if job is None:
                    return {"PASS_THROUGH"}
                if job.kind == "relight" and isinstance(job.error, session.DarkResult):
                    # a light moved into the object: said, the last colours
                    # kept, and Live waits for the next change of light
                    s.lights = job.job["lights_signature"]
                    failed = messages.failure(job.error, subject(self.obj, context.scene, s))
                    s.status = failed.text
                    _report_notes(self, s, [failed])
                elif job.error is not None:
                    self.cancel(context)
                    return _report_failure(self, s, job.error)
                elif job.kind == "setup":
                    s.finish(self.obj, job.job)
                    _show(self.obj)
                    _report_warnings(self, s)
                else:
                    s.relight_finish(self.obj, job.job)
                    if any(n.kind == "dark" for n in s.notes):  # lit again
                        s.notes = [n for n in s.notes if n.kind != "dark"]
                        s.warnings = [n.text for n in s.notes]
                        self._live_status()
                self.updates += job.error is None
                _redraw(context, ("VIEW_3D",))
            # the next update starts in the same tick, so that its solve runs
            # while Blender redraws the last one
            if s.needs_setup(self.obj, context.scene, context.evaluated_depsgraph_get()):
                self.start(context, self.obj, s, LIVE_TICK_S)
            elif s.lights_changed(context.scene):
                self.job = session.Job(s, s.relight_gather(context.scene), s.relight_compute)
        except (ohmlib.Error, OSError, RuntimeError) as e:
            self.cancel(context)
            return _report_failure(self, s, e)
        elapsed = time.perf_counter() - self.t0
        if elapsed >= 1.0:
            s.updates_per_second = self.updates / elapsed
            self.updates, self.t0 = 0, time.perf_counter()
            if self.job is None or self.job.kind != "setup":
                self._live_status()
            _redraw(context, ("PROPERTIES",))
        return {"PASS_THROUGH"}

    def cancel(self, context):
        self.detach(context)
        self.stop_job(context)


def remove_bake(obj, directory):
    """What an earlier bake of obj left: its .vdb files in directory, its
    per-frame attributes and the modifier that shows them."""
    bridge.drop_frames(obj)
    for path in glob.glob(os.path.join(glob.escape(directory), glob.escape(obj.name) + "_[0-9][0-9][0-9][0-9].vdb")):
        os.remove(path)
    pattern = re.compile(re.escape(obj.ohm.attribute) + r"_\d{4}$")
    me = obj.data
    for name in [a.name for a in me.attributes if pattern.match(a.name)]:
        me.attributes.remove(me.attributes[name])


class _BakeRun:
    """A bake's state, frame by frame: the frames solved so far, the
    exposure they share, and what to put back when it ends (the frame
    shown, an automatic exposure)."""

    def __init__(self, context, obj):
        sc = context.scene
        self.obj, self.scene = obj, sc
        self.directory = output_directory(obj)
        self.session = session.get_or_create(obj)
        self.session.begin_run()
        self.frames = list(range(sc.frame_start, sc.frame_end + 1))
        self.index, self.solved, self.exposure = 0, [], None
        self.keep_frame, self.keep_exposure = sc.frame_current, obj.ohm.exposure
        os.makedirs(self.directory, exist_ok=True)
        remove_bake(obj, self.directory)

    def done(self):
        return self.index >= len(self.frames)

    def show_frame(self, context):
        """The next frame on screen; True when it needs a new setup."""
        self.scene.frame_set(self.frames[self.index])
        return self.session.needs_setup(self.obj, self.scene, context.evaluated_depsgraph_get())

    def finish_frame(self, what):
        """The frame's result written, unless nothing changed since the last."""
        s, obj, f = self.session, self.obj, self.frames[self.index]
        self.index += 1
        if what is None and self.solved:
            return  # nothing changed: the last frame's result stands
        if not self.solved and obj.ohm.exposure == 0:
            obj.ohm.exposure = s.exposure  # chosen once, for the whole sequence
        s.scene.run("write", file=self.file(f))
        self.exposure = bridge.write_colours(obj, bridge.frame_attribute(obj.ohm.attribute, f), s.mesh_exitance(),
                                             obj.ohm.exposure)
        self.solved.append(f)

    def file(self, frame):
        return os.path.join(self.directory, "%s_%04d.vdb" % (self.obj.name, frame))

    def step(self, context):
        """One frame on this thread."""
        self.show_frame(context)
        self.finish_frame(self.session.update(self.obj, self.scene, context.evaluated_depsgraph_get()))

    def restore(self):
        self.obj.ohm.exposure = self.keep_exposure
        self.scene.frame_set(self.keep_frame)

    def show(self, context):
        """The frames baked so far render as they play (after restore, whose
        automatic exposure would recolour): the frames modifier and ohm's
        group in the materials (bridge.show_frames), and with Volume object
        a sequence volume over one file per frame, a frame that kept the
        last result a link to its file (Blender drops a gap in a sequence)."""
        obj = self.obj
        if not self.solved:
            return
        bridge.show_frames(obj, obj.ohm.attribute, self.solved)
        if obj.ohm.show_result:
            bridge.show_result(obj, obj.ohm.attribute)
        if obj.ohm.make_volume:
            baked = self.frames[:self.index]
            for f in baked:
                if not os.path.exists(self.file(f)):
                    self._link(self.file(max(g for g in self.solved if g <= f)), self.file(f))
            add_volume(context, obj, self.session, self.file(baked[0]), (baked[0], len(baked)), self.exposure)

    @staticmethod
    def _link(source, path):
        try:
            os.link(source, path)
        except OSError:  # a file system without hard links
            shutil.copyfile(source, path)

    def progress(self):
        """The status while it bakes: the frame being solved, counted from 1."""
        k = min(self.index + 1, len(self.frames))
        return "baking frame %d (%d of %d; Esc to stop)" % (self.frames[k - 1], k, len(self.frames))

    def summary(self, ended="baked"):
        solved = ", ".join(str(f) for f in self.solved[:6]) + (", ..." if len(self.solved) > 6 else "")
        last = self.frames[self.index - 1] if self.index else self.frames[0]
        return "%s frames %d-%d: %d solved (%s), exposure %.4g, in %s" % (
            ended, self.frames[0], last, len(self.solved), solved, self.session.exposure or 0, self.directory)


class OHM_OT_bake(bpy.types.Operator):
    """Bake the animation over the frame range: frames where a light, the object or its material changed are solved
    (one setup for all of them while the geometry stays), each written as a .vdb and a colour attribute named by its
    first frame; a frame where nothing changed keeps the last.  One exposure for the whole sequence.  Renders then
    show each frame's result (with Volume object, a sequence volume too).  Runs frame by frame in the background: Esc
    stops it, keeping the frames written"""
    bl_idname = "ohm.bake"
    bl_label = "Bake sequence"
    bl_options = {"UNDO"}

    @classmethod
    def poll(cls, context):
        return _idle_mesh_poll(context)

    def execute(self, context):
        try:
            run = _BakeRun(context, context.active_object)
        except OSError as e:
            return _report_failure(self, session.get_or_create(context.active_object), e)
        wm = context.window_manager
        wm.progress_begin(0, len(run.frames))
        try:
            while not run.done():
                run.step(context)
                wm.progress_update(run.index)
        except (ohmlib.Error, OSError) as e:
            return _report_failure(self, run.session, e)
        finally:
            wm.progress_end()
            run.restore()
            run.show(context)
        return self._done(run)

    def invoke(self, context, event):
        try:
            self.run = _BakeRun(context, context.active_object)
        except OSError as e:
            return _report_failure(self, session.get_or_create(context.active_object), e)
        self.job = None
        self.run.session.status = self.run.progress()
        wm = context.window_manager
        wm.progress_begin(0, len(self.run.frames))
        self._timer = wm.event_timer_add(JOB_TICK_S, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        run, s = self.run, self.run.session
        if event.type == "ESC" and event.value == "PRESS":
            if self.job is not None:
                self.job.cancel()
                self.job.end()
            return self._stop(context, cancelled=True)
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            if self.job is not None:  # a frame's setup, in the background
                if not self.job.done():
                    return {"PASS_THROUGH"}
                self.job.end()
                job, self.job = self.job, None
                if job.error is not None:
                    raise job.error
                s.finish(run.obj, job.job)
                run.finish_frame("setup")
            elif run.done():
                return self._stop(context)
            elif run.show_frame(context):
                self.job = session.Job(s, s.gather(run.obj, run.scene, context.evaluated_depsgraph_get()))
            else:
                run.finish_frame(s.update(run.obj, run.scene, context.evaluated_depsgraph_get()))
        except ReferenceError:
            return self._stop(context, cancelled=True)
        except (ohmlib.Error, OSError, RuntimeError) as e:
            self._stop(context, cancelled=True)
            return _report_failure(self, s, e)
        context.window_manager.progress_update(run.index)
        status = run.progress()
        if status != s.status:
            s.status = status
            _status_bar(context, "ohm: " + status)
            _redraw(context, ("PROPERTIES",))
        return {"PASS_THROUGH"}

    def _stop(self, context, cancelled=False):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        _status_bar(context, None)
        try:
            self.run.restore()
            self.run.show(context)
        except ReferenceError:
            return {"CANCELLED"}
        if cancelled:
            self.run.session.status = self.run.summary("stopped after")
            self.report({"WARNING"}, "ohm: " + self.run.session.status)
            return {"CANCELLED"}
        return self._done(self.run)

    def _done(self, run):
        run.session.status = run.summary()
        _report_warnings(self, run.session)
        self.report({"INFO"}, "ohm: " + run.session.status)
        return {"FINISHED"}


class OHM_OT_remove(bpy.types.Operator):
    """Remove what ohm added to the object: its node group from the materials (their links as they were), its own
    material, a bake's frames, the colour attributes and the volume object.  The .vdb files stay.  Ctrl-Z brings
    it back"""
    bl_idname = "ohm.remove"
    bl_label = "Remove ohm result"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return _idle_mesh_poll(context) and bridge.has_result(context.active_object, context.active_object.ohm.attribute)

    def execute(self, context):
        obj = context.active_object
        bridge.remove_result(obj, obj.ohm.attribute)
        s = session.get(obj)
        if s is not None:
            s.lights = None  # Live's next update writes the result again
            s.status = "ohm's result removed"
        self.report({"INFO"}, "ohm: result removed from %s" % obj.name)
        _redraw(context)
        return {"FINISHED"}


classes = (OHM_OT_solve, OHM_OT_cancel, OHM_OT_auto_exposure, OHM_OT_live, OHM_OT_bake, OHM_OT_remove)
