"""blender_reports.py — what the artist reads and sees, in a headless
Blender's default scene (tests/cli_blender_reports.sh):

  blender -b --factory-startup --python-exit-code 1 -P tests/blender_reports.py -- ZIP OUTDIR REPORT.json MODE

MODE reports: a zero-scale object, an empty mesh, a flat plane and a light
inside the object each fail with an ERROR report (Blender's own report
lines, read from its output) that names the object (and the light) in the
artist's words; an accuracy target finer than Memory allows names the
panel's settings; a large object's warning suggests Scale.  No report and no
text the panel draws holds the command line's syntax ("-voxelize",
"argument 1", "type=").

MODE live: Live relight's updates keep the exposure the first result chose:
the light's power at 0.1x makes the colours, and a Cycles render of them,
0.1x; a red light then a blue one changes the red channel by more than 10x;
a light moved into the object is an ERROR, the colours kept.

MODE suzanne: the default Suzanne at Blender's default scale and the
panel's defaults, lit from behind, rendered in Cycles from the front with
the default Scale: its ears are brighter than the unlit face (light shows
through them).  Prints the figures at other Scales too (docs/blender-addon.md
quotes them; at 1 unit = 1 m the cells are coarser than an ear, which the
warning says, and the figures are the grid's, not the material's).

Any failed check raises, so Blender exits 1."""
import ctypes
import json
import os
import sys
import tempfile
import types

import bpy
import numpy as np

args = sys.argv[sys.argv.index("--") + 1:]
ZIP, OUT, REPORT, MODE = args[:4]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_scene import install_addon  # noqa: E402

install_addon(ZIP)
from ohm_blender import messages, operators, session, ui  # noqa: E402  (installed just now)

report = {"mode": MODE, "problems": []}
libc = ctypes.CDLL(None)


def problem(text):
    report["problems"].append(text)
    print("PROBLEM:", text)


def reported(call):
    """(call's result, Blender's report lines): in the background Blender
    prints each report as 'Error: ...', 'Warning: ...' or 'Info: ...';
    both output streams are caught while call runs.  An operator's ERROR
    report raised as RuntimeError is its result."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        try:
            try:
                result = call()
            except RuntimeError as e:
                result = e
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            libc.fflush(None)
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
        tmp.seek(0)
        out = tmp.read().decode("utf-8", "replace")
    sys.stdout.write(out)
    lines = [line for line in out.splitlines() if line.startswith(("Error: ", "Warning: ", "Info: "))]
    if isinstance(result, RuntimeError):  # its text holds the ERROR reports too
        lines += [line for line in str(result).splitlines() if line.startswith("Error: ")]
    return result, lines


class PanelText:
    """A layout that keeps every text the panel would draw (labels, the
    settings' names, the buttons' labels)."""

    def __init__(self):
        self.texts = []
        self.use_property_split = self.use_property_decorate = self.enabled = True

    def column(self, **_):
        return self

    row = box = split = column

    def separator(self, **_):
        pass

    def label(self, text="", **_):
        self.texts.append(text)

    def prop(self, data, name, text=None, **_):
        self.texts.append(text if text is not None else data.bl_rna.properties[name].name)

    def operator(self, idname, text=None, **_):
        self.texts.append(text if text is not None else idname)


def panel_text():
    layout = PanelText()
    ui.OHM_PT_object.draw(types.SimpleNamespace(layout=layout), bpy.context)
    return layout.texts


def check_words(what, lines):
    """No command-line syntax in lines."""
    for line in lines:
        if messages.CLI_SYNTAX.search(line):
            problem("%s: command-line syntax in %r" % (what, line))


def default_scene():
    """Blender's default scene without its cube: its Light, its Camera."""
    for o in list(bpy.data.objects):
        if o.type == "MESH":
            bpy.data.objects.remove(o)
    return bpy.context.scene, bpy.data.objects["Light"]


def select(obj):
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    obj.ohm.dim = 24
    obj.ohm.solver = "direct"


def monkey():
    bpy.ops.mesh.primitive_monkey_add()
    obj = bpy.context.active_object
    select(obj)
    return obj


def expect_error(case, call, words):
    """call fails with an ERROR report holding every one of words."""
    result, lines = reported(call)
    errors = [line for line in lines if line.startswith("Error: ")]
    report.setdefault("errors", {})[case] = errors[:1]
    if result == {"FINISHED"} or not any(all(w in line for w in words) for line in errors):
        problem("%s: %s with ERROR reports %s, expected one saying %s" % (case, result, errors, words))
    check_words(case + " reports", lines)
    check_words(case + " panel", panel_text())
    return lines


def cycles_mean(path, size=48, ortho=3.2, location=(0.0, -10.0, 0.0)):
    """A Cycles render of the scene from `location` looking +y,
    orthographic, black world: its linear pixels (an OpenEXR file, which
    holds the render's own values, not the view transform's), rows from the
    bottom."""
    sc = bpy.context.scene
    cam = bpy.data.objects["Camera"]
    cam.data.type, cam.data.ortho_scale = "ORTHO", ortho
    cam.location, cam.rotation_euler = location, (np.pi / 2, 0.0, 0.0)
    sc.camera = cam
    sc.world.use_nodes, sc.world.color = False, (0.0, 0.0, 0.0)
    sc.render.engine = "CYCLES"
    sc.cycles.samples, sc.cycles.use_denoising = 8, False
    sc.render.resolution_x = sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    px = np.array(img.pixels[:], dtype=np.float64).reshape(size, size, 4)
    bpy.data.images.remove(img)
    return px


def colours(obj):
    me = obj.data
    c = np.empty(4 * len(me.vertices), dtype=np.float32)
    me.attributes[obj.ohm.attribute].data.foreach_get("color", c)
    return c.reshape(-1, 4)[:, :3].astype(np.float64)


if MODE == "reports":
    sc, light = default_scene()
    # a zero-scale object
    obj = monkey()
    obj.scale = (0.0, 0.0, 0.0)
    expect_error("zero scale", lambda: bpy.ops.ohm.solve(), ["Suzanne", "no size"])
    bpy.data.objects.remove(obj)
    # an empty mesh
    obj = bpy.data.objects.new("Empty mesh", bpy.data.meshes.new("Empty mesh"))
    sc.collection.objects.link(obj)
    select(obj)
    expect_error("empty mesh", lambda: bpy.ops.ohm.solve(), ["Empty mesh", "no faces"])
    bpy.data.objects.remove(obj)
    # a flat plane
    bpy.ops.mesh.primitive_plane_add()
    obj = bpy.context.active_object
    select(obj)
    expect_error("flat plane", lambda: bpy.ops.ohm.solve(), ["Plane", "flat", "Solidify"])
    bpy.data.objects.remove(obj)
    # a light inside the object: an error, not a black object (no attribute written)
    obj = monkey()
    light.location = (0.0, 0.0, 0.0)
    expect_error("light inside", lambda: bpy.ops.ohm.solve(), ["No light reaches Suzanne", "Light"])
    if obj.ohm.attribute in obj.data.attributes:
        problem("a light inside the object still wrote colours")
    # the same light outside: a result; then inside again: its colours are kept
    light.location = (4.0, -3.0, 2.0)
    result, lines = reported(lambda: bpy.ops.ohm.solve())
    check_words("a solve's reports", lines)
    check_words("a solve's panel", panel_text())
    if result != {"FINISHED"}:
        problem("Solve with the light outside: %s %s" % (result, lines))
    # a large object: the warning names Scale and Cells, in the panel's words
    obj.ohm.scale = 1000.0  # 1 unit = 1 m: Suzanne 2.7 m across
    result, lines = reported(lambda: bpy.ops.ohm.solve())
    report["large_object_warning"] = [line for line in lines if "Scale" in line]
    if not any(line.startswith("Warning: ") and "Lower Scale to about" in line and "Cells" in line for line in lines):
        problem("Suzanne 2.7 m across: no warning suggesting Scale: %s" % lines)
    check_words("a large object's reports", lines)
    check_words("a large object's panel", panel_text())
    obj.ohm.scale = 0.0
    # an accuracy target the Memory cannot hold: the panel's settings named
    obj.ohm.grid, obj.ohm.error, obj.ohm.max_memory = "ERROR", 0.001, 5
    lines = expect_error("accuracy target", lambda: bpy.ops.ohm.solve(), ["Accuracy target", "Error 0.001",
                                                                          "Cells", "Memory 5%"])
    obj.ohm.grid, obj.ohm.max_memory = "DIM", 50
    # Memory shows as a percentage
    if obj.ohm.bl_rna.properties["max_memory"].subtype != "PERCENTAGE" or obj.ohm.max_memory_fraction != 0.5:
        problem("Memory is not a percentage: %s, fraction %s" % (obj.ohm.max_memory, obj.ohm.max_memory_fraction))
    # the add-on's and the library's words for every entry of the table, as the add-on words them
    for raw in ("argument 1: -voxelize error=0.001 needs dim=2032 (predicted error 0.001 there), more than "
                "max_dim=587 allows; use a larger error=",
                "argument 1: -light type=spot reaches no part of the object (it misses it, or what it faces is in "
                "shadow): it adds no light",
                "voxel 55 mm is larger than the diffusion length 1/sigma_tr = 3.7 mm of channel R: the grid cannot "
                "resolve how light spreads, expect large errors (use a smaller voxel, or -voxelize error=)",
                "material skin1 R has albedo 0.678 < 0.8: the diffusion approximation is poor there (light is "
                "absorbed before it scatters enough); expect errors of tens of percent"):
        about = operators.subject(obj, sc)
        notes = messages.warnings([raw], about) + [messages.failure(session.ohmlib.Error(-5, raw), about)]
        check_words("the words for %r" % raw, [t for n in notes for t in (n.text, n.details)])

elif MODE == "live":
    sc, light = default_scene()
    obj = monkey()
    light.location = (3.0, -3.0, 1.0)
    light.data.energy = 1000.0
    if operators.live_step(bpy.context, obj) != "setup":
        problem("Live's first update was no setup")
    s = session.get(obj)
    before = colours(obj)
    pixels_before = cycles_mean(os.path.join(OUT, "live_full.exr"))
    exposure = s.exposure
    # the light's power at 0.1x: the colours 0.1x, the exposure kept
    light.data.energy = 100.0
    if operators.live_step(bpy.context, obj) != "relight":
        problem("a change of power was not a relight")
    after = colours(obj)
    pixels_after = cycles_mean(os.path.join(OUT, "live_tenth.exr"))
    ratio = float(after.mean() / before.mean())
    lit = pixels_before[:, :, :3] > 0.01
    render_ratio = float(pixels_after[:, :, :3][lit].mean() / pixels_before[:, :, :3][lit].mean())
    report["power_tenth"] = {"colours": ratio, "cycles": render_ratio, "exposure": [exposure, s.exposure]}
    if abs(ratio - 0.1) > 0.002 or abs(render_ratio - 0.1) > 0.002 or s.exposure != exposure:
        problem("the light's power at 0.1x: colours %.4g x, Cycles %.4g x, exposure %s -> %s" % (
            ratio, render_ratio, exposure, s.exposure))
    # a red light, then a blue one: the red channel follows
    light.data.energy = 1000.0
    light.data.color = (1.0, 0.0, 0.0)
    operators.live_step(bpy.context, obj)
    red = colours(obj)[:, 0].mean()
    light.data.color = (0.0, 0.0, 1.0)
    operators.live_step(bpy.context, obj)
    blue = colours(obj)[:, 0].mean()
    report["red_channel_red_blue"] = [float(red), float(blue)]
    if not red > 10 * blue:
        problem("a red light then a blue one: the red channel's mean %.4g then %.4g" % (red, blue))
    # Auto exposure chooses again: the brightest 1% of the result white
    light.data.color = (1.0, 1.0, 1.0)
    light.data.energy = 10.0
    operators.live_step(bpy.context, obj)
    reported(lambda: bpy.ops.ohm.auto_exposure())
    shown = float(np.percentile(colours(obj)[colours(obj) > 0], 99))
    report["auto_exposure_p99"] = shown
    if abs(shown - 1.0) > 0.05 or obj.ohm.exposure != s.exposure:
        problem("Auto exposure: the brightest 1%% at %.4g, Exposure %s (used %s)" % (shown, obj.ohm.exposure,
                                                                                    s.exposure))
    # the light moved into the object: an error, the last colours kept
    kept = colours(obj)
    light.location = (0.0, 0.0, 0.0)
    try:
        operators.live_step(bpy.context, obj)
        problem("a light inside the object relit without an error")
    except session.DarkResult as e:
        note = messages.failure(e, operators.subject(obj, sc))
        report["light_inside_live"] = note.text
        if note.level != "ERROR" or "Light" not in note.text or not np.array_equal(colours(obj), kept):
            problem("a light inside the object in Live: %s %r, colours kept %s" % (
                note.level, note.text, np.array_equal(colours(obj), kept)))

elif MODE == "suzanne":
    sc, light = default_scene()
    bpy.ops.mesh.primitive_monkey_add()  # Blender's default: size 2, at the origin, facing -y
    obj = bpy.context.active_object
    light.location, light.data.energy = (0.0, 4.0, 0.3), 1000.0  # behind the head
    verts = np.array([v.co[:] for v in obj.data.vertices])
    size = 64
    ortho = 3.2

    def pixel_box(x0, x1, z0, z1):
        """The image pixels over world x in [x0, x1], z in [z0, z1] (the
        camera at -y looking +y, orthographic: x to the right, z up)."""
        def col(x):
            return int(round((x / ortho + 0.5) * size))
        return slice(col(z0), col(z1)), slice(col(x0), col(x1))

    ears = verts[np.abs(verts[:, 0]) > 1.05]
    ear_z = (float(ears[:, 2].min()), float(ears[:, 2].max()))
    boxes = {"left ear": pixel_box(-1.33, -1.1, *ear_z), "right ear": pixel_box(1.1, 1.33, *ear_z),
             "face": pixel_box(-0.45, 0.45, -0.5, 0.3)}
    ratios = {}
    # the panel's defaults at the default Scale; other Scales; and the
    # default Scale at cells finer than the shortest spread (3.9 mm in blue):
    # the ears' light is the material's, not the grid's
    for scale, dim in ((0.0, 48), (1000.0, 48), (300.0, 48), (30.0, 48), (0.0, 96)):
        obj.ohm.scale, obj.ohm.dim = scale, dim
        bpy.context.view_layer.objects.active = obj
        result, lines = reported(lambda: bpy.ops.ohm.solve())
        if result != {"FINISHED"}:
            problem("Solve at Scale %g: %s %s" % (scale, result, lines))
            continue
        bpy.ops.ohm.auto_exposure()
        px = cycles_mean(os.path.join(OUT, "suzanne_scale_%g_cells_%d.exr" % (scale, dim)), size, ortho)
        lum = 0.2126 * px[:, :, 0] + 0.7152 * px[:, :, 1] + 0.0722 * px[:, :, 2]
        mean = {k: float(lum[b].mean()) for k, b in boxes.items()}
        ear = min(mean["left ear"], mean["right ear"])
        ratios["%g/%d" % (scale, dim)] = {"ear_over_face": ear / max(mean["face"], 1e-6), **mean}
        print("SUZANNE Scale %s (%.4g mm per unit), Cells %d (%d cells, cells of %.3g mm): ears %.4g, %.4g, face "
              "%.4g: ears / face %.3g" % (scale or "Auto", session.get(obj).mm_per_unit, dim,
                                          session.get(obj).result["unknowns"], session.get(obj).scene.grid["voxel"],
                                          mean["left ear"], mean["right ear"], mean["face"],
                                          ear / max(mean["face"], 1e-6)))
    report["suzanne"] = ratios
    for key in ("0/48", "0/96"):
        auto = ratios.get(key)
        if not auto or not (auto["ear_over_face"] > 3 and min(auto["left ear"], auto["right ear"]) > 0.03):
            problem("Suzanne at the default Scale (Scale/Cells %s) shows no light through its ears: %s" % (key, auto))

json.dump(report, open(REPORT, "w"), indent=1)
if report["problems"]:
    raise SystemExit("blender_reports: %d problem(s)" % len(report["problems"]))
print("blender_reports %s: ok" % MODE)
