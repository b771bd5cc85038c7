"""Blender's scene in ohm's terms: units, the mesh as placed, the lights,
and the colour attribute written back.  No state of its own."""
import math

import numpy as np

try:  # the package bundled into the add-on's zip, as session.py finds it
    from . import ohm as ohmlib
except ImportError:  # running from a source tree with ohm on sys.path
    import ohm as ohmlib


# Scale Auto's millimetres per unit where the scene keeps Blender's default
# units (docs/blender-addon.md, "Scale"): a new file's 1 unit = 1 m is the
# size its primitives are made at (the cube 2 units, Suzanne 2.7), not a
# measurement, and at 2.7 m every measured material is opaque (light spreads
# 1-10 mm in them); 100 mm per unit makes those objects 20-27 cm, a head's
# or a fruit's size, where light shows through an ear.
DEFAULT_SCENE_UNIT_MM = 100.0


def scene_keeps_default_units(scene):
    """Blender's default units: Metric (or None), Unit Scale 1, Length in
    metres or adaptive: nothing says what a unit is."""
    us = scene.unit_settings
    return us.scale_length == 1.0 and (us.system == "NONE" or (us.system == "METRIC" and
                                                               us.length_unit in ("METERS", "ADAPTIVE")))


def auto_mm_per_unit(scene):
    """Scale Auto: the scene's unit (Unit Scale x 1000 mm) where its unit
    settings were changed, DEFAULT_SCENE_UNIT_MM where they are Blender's
    defaults."""
    if scene_keeps_default_units(scene):
        return DEFAULT_SCENE_UNIT_MM
    return scene.unit_settings.scale_length * 1000.0


def mm_per_unit(scene, obj):
    """Millimetres of material per Blender unit for obj: its Scale, or when
    0 (Auto) auto_mm_per_unit.  Lights are placed with the same figure, so
    the whole scene is solved at the object's scale."""
    scale = obj.ohm.scale
    return scale if scale > 0 else auto_mm_per_unit(scene)


def evaluated_mesh(obj, depsgraph):
    """The object's mesh as Blender shows it, modifiers and shape keys
    applied (depsgraph None: the mesh's own data): vertices in object space
    (n, 3) float64 and triangles (m, 3) int64."""
    src = obj.evaluated_get(depsgraph) if depsgraph is not None else obj
    me = src.to_mesh() if depsgraph is not None else obj.data
    try:
        me.calc_loop_triangles()
        co = np.empty(3 * len(me.vertices), dtype=np.float64)
        me.vertices.foreach_get("co", co)
        tris = np.empty(3 * len(me.loop_triangles), dtype=np.int32)
        me.loop_triangles.foreach_get("vertices", tris)
    finally:
        if depsgraph is not None:
            src.to_mesh_clear()
    return co.reshape(-1, 3), tris.reshape(-1, 3).astype(np.int64)


def world_mm(obj, local, mm):
    """Object-space vertices placed in the world, in mm."""
    m = np.array(obj.matrix_world, dtype=np.float64)
    return (local @ m[:3, :3].T + m[:3, 3]) * mm


def to_original(obj, local):
    """For each of the mesh's own vertices, the evaluated vertex whose
    colour it shows: None when the modifiers keep the vertices (deforming
    ones, shape keys: the same count, the same order), else the nearest
    evaluated vertex in object space (a subdivision keeps a vertex near each
    original one, an array's first copy is the original).  The colour
    attribute lives on the mesh's own vertices, and Blender carries it
    through the modifiers."""
    me = obj.data
    if len(me.vertices) == len(local):
        return None
    from mathutils import kdtree
    tree = kdtree.KDTree(len(local))
    for i, co in enumerate(local):
        tree.insert(co, i)
    tree.balance()
    own = np.empty(3 * len(me.vertices), dtype=np.float64)
    me.vertices.foreach_get("co", own)
    return np.array([tree.find(co)[1] for co in own.reshape(-1, 3)], dtype=np.int64)


def memory_budget_mb(fraction):
    """(the MB a solve may take, the MB available now): `fraction` of the
    memory available (MemAvailable, lowered by a cgroup limit), leaving
    Blender the rest."""
    avail = 0.0
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    avail = float(line.split()[1]) * 1024.0
        for limit_path, used_path in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),):
            try:
                limit = float(open(limit_path).read().split()[0])
                used = float(open(used_path).read().split()[0])
                avail = min(avail, max(0.0, limit - used))
            except (OSError, ValueError):
                pass
    except OSError:
        pass
    if avail <= 0:  # not Linux: os.sysconf where there is one
        import os
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            avail = 4.0 * 2 ** 30
    return max(64.0, fraction * avail / 2 ** 20), avail / 2 ** 20


def _vec(v):
    return tuple(float(x) for x in v)


def light_options(obj, mm):
    """One Blender light as ohm's -light options, or None for a light ohm
    has no model of.  Blender's powers are radiant: a point or spot light of
    P watts has intensity P / 4 pi W/sr (a spot's cone does not change it),
    a sun's strength is W/m^2 (1e-6 W/mm^2), an area light's power is what it
    emits in all.  Lights shine along their local -Z axis."""
    light = obj.data
    m = np.array(obj.matrix_world, dtype=np.float64)
    pos = m[:3, 3] * mm
    axis = -m[:3, 2]
    axis = axis / (np.linalg.norm(axis) or 1.0)
    colour = np.array(light.color[:3], dtype=np.float64)
    if light.type == "SUN":
        return {"type": "directional", "dir": _vec(axis), "intensity": _vec(colour * light.energy * 1e-6)}
    if light.type == "POINT":
        return {"type": "point", "pos": _vec(pos), "intensity": _vec(colour * light.energy / (4 * math.pi))}
    if light.type == "SPOT":
        half = math.degrees(light.spot_size) / 2
        return {"type": "spot", "pos": _vec(pos), "dir": _vec(axis), "angle": max(0.01, min(90.0, half)),
                "falloff": max(0.0, min(90.0, half * light.spot_blend)),
                "intensity": _vec(colour * light.energy / (4 * math.pi))}
    if light.type == "AREA":
        sx = light.size * mm * float(np.linalg.norm(m[:3, 0]))
        sy = (light.size_y if light.shape in ("RECTANGLE", "ELLIPSE") else light.size) * mm * float(np.linalg.norm(m[:3, 1]))
        return {"type": "area", "pos": _vec(pos), "dir": _vec(axis), "shape": "disk" if light.shape in ("DISK", "ELLIPSE") else "rect",
                "width": max(sx, 1e-6), "height": max(sy, 1e-6), "intensity": _vec(colour * light.energy)}
    return None


def _world_background(world):
    """The World's Background node feeding its output (None without nodes)."""
    if not world.use_nodes or world.node_tree is None:
        return None
    for node in world.node_tree.nodes:
        if node.type == "OUTPUT_WORLD" and node.is_active_output and node.inputs["Surface"].is_linked:
            bg = node.inputs["Surface"].links[0].from_node
            return bg if bg.type == "BACKGROUND" else None
    return None


def world_light(scene):
    """The World as ohm's environment light, or None (World.ohm_light off,
    or a black sky).  Its radiance is colour x strength in W/m^2/sr, as a
    sun's strength is W/m^2 (1e-6 W/mm^2/sr); an Environment Texture's image
    (Blender's equirectangular mapping, z up, which ohm's sky= shares)
    becomes sky=, its pixels times the strength."""
    world = scene.world
    if world is None or not getattr(world, "ohm_light", False):
        return None
    bg = _world_background(world)
    if bg is None:
        colour, strength, image = np.array(world.color[:3], dtype=np.float64), 1.0, None
    else:
        colour_in = bg.inputs["Color"]
        strength = float(bg.inputs["Strength"].default_value)
        colour, image = np.array(colour_in.default_value[:3], dtype=np.float64), None
        if colour_in.is_linked:
            src = colour_in.links[0].from_node
            if src.type == "TEX_ENVIRONMENT" and src.image is not None:
                image, colour = _sky_file(src.image), np.ones(3)
    radiance = colour * strength * 1e-6
    if image is None and not radiance.any():
        return None
    opts = {"type": "environment", "intensity": _vec(radiance)}
    if image:
        opts["sky"] = image
    return opts


def _sky_file(image):
    """The file an Environment Texture's image reads, absolute; a packed or
    generated image has none ohm could read (its path is empty, and
    bpy.path.abspath("") is the .blend's folder): refused, as session.py's
    refusals are."""
    import bpy
    path = image.filepath_raw or image.filepath
    if image.packed_file is not None or not path:
        raise ohmlib.UsageError(ohmlib.ERR_USAGE, "the World's Environment Texture image '%s' is packed or generated: "
                                "save it to a .hdr or .exr file first" % image.name)
    return bpy.path.abspath(path)


def light_names(scene):
    """The names of what scene_lights returns, in its order ("World" for
    the World), for messages that name a light."""
    names = [obj.name for obj in scene.objects
             if obj.type == "LIGHT" and not obj.hide_render and obj.data.type in ("SUN", "POINT", "SPOT", "AREA")]
    return names + (["World"] if world_light(scene) else [])


def scene_lights(scene, mm):
    """Every visible light of the scene, and the World when it lights the
    object (world_light), as ohm options."""
    out = []
    for obj in scene.objects:
        if obj.type == "LIGHT" and not obj.hide_render:
            opts = light_options(obj, mm)
            if opts:
                out.append(opts)
    sky = world_light(scene)
    if sky:
        out.append(sky)
    return out


def lights_signature(scene):
    """What a change of light is: placement, colour, power, shape."""
    sig = []
    for obj in scene.objects:
        if obj.type == "LIGHT" and not obj.hide_render:
            light = obj.data
            sig.append((obj.name, tuple(tuple(r) for r in obj.matrix_world), tuple(light.color), light.energy,
                        light.type, getattr(light, "spot_size", 0), getattr(light, "spot_blend", 0),
                        getattr(light, "size", 0), getattr(light, "size_y", 0)))
    sky = world_light(scene)
    if sky:
        sig.append(("World", tuple(sorted((k, str(v)) for k, v in sky.items()))))
    return tuple(sig)


def exposure_for(exitance, exposure):
    """exposure, or when 0 the one that maps the 99th percentile to 1."""
    if exposure > 0:
        return exposure
    lit = exitance[exitance > 0]
    p99 = float(np.percentile(lit, 99)) if lit.size else 0.0
    return 1.0 / p99 if p99 > 0 else 1.0


def write_colours(obj, name, exitance, exposure):
    """exitance (vertices, channels) as a point-domain colour attribute,
    colour = exitance x exposure (linear); returns the exposure used."""
    me = obj.data
    used = exposure_for(exitance, exposure)
    rgba = np.ones((exitance.shape[0], 4), dtype=np.float32)
    rgb = exitance * used
    rgba[:, :3] = rgb if rgb.shape[1] == 3 else np.repeat(rgb[:, :1], 3, axis=1)
    attr = me.attributes.get(name)
    if attr is not None and (attr.domain != "POINT" or attr.data_type != "FLOAT_COLOR"):
        me.attributes.remove(attr)
        attr = None
    if attr is None:
        attr = me.attributes.new(name, "FLOAT_COLOR", "POINT")
    attr.data.foreach_set("color", rgba.ravel())
    me.update()
    return used


def show_result(obj, attribute):
    """Make the colour attribute visible without wiring: a material (its
    first slot) whose surface emits the attribute's colour, which is the
    light leaving the surface (exitance x exposure), in Cycles and EEVEE;
    the attribute active, so the viewport's Attribute colouring shows it;
    and the 3D views' solid shading coloured by it."""
    import bpy
    name = "ohm " + obj.name
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    emit = nt.nodes.new("ShaderNodeEmission")
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_type = "GEOMETRY"
    attr.attribute_name = attribute
    attr.location, emit.location, out.location = (-400, 0), (-150, 0), (100, 0)
    nt.links.new(attr.outputs["Color"], emit.inputs["Color"])
    emit.inputs["Strength"].default_value = 1.0
    nt.links.new(emit.outputs["Emission"], out.inputs["Surface"])
    me = obj.data
    if not me.materials:
        me.materials.append(mat)
    elif me.materials[0] is not mat:
        me.materials[0] = mat
    if attribute in me.color_attributes:
        me.color_attributes.active_color = me.color_attributes[attribute]
    for screen in bpy.data.screens:
        for area in screen.areas:
            if area.type == "VIEW_3D":
                for space in area.spaces:
                    if space.type == "VIEW_3D":  # "Attribute" in the menu; "VERTEX" to the API in 3.x
                        items = space.shading.bl_rna.properties["color_type"].enum_items.keys()
                        space.shading.color_type = "ATTRIBUTE" if "ATTRIBUTE" in items else "VERTEX"
    return mat


def volume_name(obj):
    """The name of obj's volume object and of its material."""
    return obj.name + "_ohm"


def volume_material(name, channels, uniform, mm, exposure):
    """The solution as a volume that looks like the object: each channel k
    has the medium's own extinction sigma_t,k = sigma_a,k + sigma_s',k as
    absorption and emits sigma_t,k * phi_k / 4 (times the exposure) per unit
    length.  In the diffusion approximation the radiance inside is nearly
    isotropic, phi / (4 pi), and scattering keeps it in place (its in-
    scattered part is sigma_s' phi / (4 pi)); as a source function S = phi /
    (4 pi) seen through extinction sigma_t, a ray leaves the volume with S
    averaged over its last mean free path (0.45 mm in marble, 0.7-1.3 mm in skin1):
    the light emerging just below the surface (the Eddington-Barbier
    relation), as in the object.  The factor pi puts it on the surface
    colour's scale (exitance x exposure, and M = pi L for a diffuse
    emitter).  channels: the solution's, 1 or 3 (grids fluence, or fluence_r,
    _g and _b); uniform: {"sigma_a_r": ..., "sigma_s_r": ...} per channel
    suffix (the library's statistics) where the medium is the same in every
    cell, None where it varies and the .vdb carries sigma_a and sigma_s per
    cell under the same names; mm: millimetres per Blender unit (the
    coefficients are per mm)."""
    import bpy
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    combine = nt.nodes.new("ShaderNodeCombineRGB") if bpy.app.version < (3, 3, 0) else \
        nt.nodes.new("ShaderNodeCombineColor")
    emit = nt.nodes.new("ShaderNodeEmission")
    emit.name = "ohm emission"
    emit.inputs["Strength"].default_value = 0.25 * exposure
    nt.links.new(combine.outputs[0], emit.inputs["Color"])
    suffixes = ("_r", "_g", "_b") if channels == 3 else ("",) * 3
    shader = emit.outputs[0]

    def attribute(grid):
        a = nt.nodes.new("ShaderNodeAttribute")
        a.attribute_name = grid
        return a.outputs["Fac"]

    def math(op, a, b):
        m = nt.nodes.new("ShaderNodeMath")
        m.operation = op
        for socket, value in zip(m.inputs, (a, b)):
            if isinstance(value, float):
                socket.default_value = value
            else:
                nt.links.new(value, socket)
        return m.outputs[0]

    for k, sfx in enumerate(suffixes):
        if uniform is not None:  # the object's mask times its coefficients
            sigma_t = math("MULTIPLY", attribute("density"), (uniform["sigma_a" + sfx] + uniform["sigma_s" + sfx]) * mm)
        else:
            sigma_t = math("MULTIPLY", math("ADD", attribute("sigma_a" + sfx), attribute("sigma_s" + sfx)), mm)
        nt.links.new(math("MULTIPLY", sigma_t, attribute("fluence" + sfx)), combine.inputs[k])
        if not sfx and k > 0:  # one channel: one absorption, of all three colours
            continue
        absorb = nt.nodes.new("ShaderNodeVolumeAbsorption")  # coefficient: Density x (1 - Color)
        absorb.inputs["Color"].default_value = tuple(0.0 if j == k or not sfx else 1.0 for j in range(3)) + (1.0,)
        nt.links.new(sigma_t, absorb.inputs["Density"])
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(shader, add.inputs[0])
        nt.links.new(absorb.outputs[0], add.inputs[1])
        shader = add.outputs[0]
    nt.links.new(shader, out.inputs["Volume"])
    return mat


def set_volume_exposure(mat, exposure):
    """A new exposure on volume_material's emission (no solve)."""
    node = mat.node_tree.nodes.get("ohm emission") if mat is not None and mat.use_nodes else None
    if node is not None:
        node.inputs["Strength"].default_value = 0.25 * exposure
