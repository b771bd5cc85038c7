"""Blender's scene in ohm's terms: units, the mesh as placed, the lights,
and the colour attribute written back.  No state of its own."""
import math
import re

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


# The object's custom property that ohm's node group reads (an Object
# attribute): 1 shows ohm's result on this object, 0 shows the artist's shader.
# Another object sharing the material has no such property, reads 0, and keeps
# its look (Cycles and EEVEE give a missing Object attribute 0).
RESULT_SHOWN = "ohm_result"
# The name prefix of ohm's shader node group, of its geometry node group that
# picks a bake's frame, and the name of the modifier that holds the latter.
RESULT_GROUP = "ohm result"
FRAMES_GROUP = "ohm frames"
FRAMES_MODIFIER = "ohm frames"
# Custom properties on ohm's own datablocks: its material (given to an
# object with none), a slot ohm added for it, and a material whose nodes ohm
# turned on to add its group.
OWN_MATERIAL = "ohm_own"
ADDED_SLOT = "ohm_added_slot"
ENABLED_NODES = "ohm_enabled_nodes"


def _result_group(attribute):
    """ohm's shader node group (one per attribute name): its Shader input
    (the artist's surface, passed through) mixed with an emission of the
    colour attribute, which is the light leaving the surface (exitance x
    exposure), by the object's RESULT_SHOWN property."""
    import bpy
    name = "%s: %s" % (RESULT_GROUP, attribute)
    tree = bpy.data.node_groups.get(name)
    if tree is not None and tree.bl_idname == "ShaderNodeTree":
        return tree
    tree = bpy.data.node_groups.new(name, "ShaderNodeTree")
    tree.inputs.new("NodeSocketShader", "Shader")
    tree.outputs.new("NodeSocketShader", "Shader")
    nodes, links = tree.nodes, tree.links
    given, result = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    colour = nodes.new("ShaderNodeAttribute")
    colour.attribute_type, colour.attribute_name = "GEOMETRY", attribute
    shown = nodes.new("ShaderNodeAttribute")
    shown.attribute_type, shown.attribute_name = "OBJECT", RESULT_SHOWN
    emit, mix = nodes.new("ShaderNodeEmission"), nodes.new("ShaderNodeMixShader")
    emit.inputs["Strength"].default_value = 1.0
    links.new(colour.outputs["Color"], emit.inputs["Color"])
    links.new(shown.outputs["Fac"], mix.inputs["Fac"])
    links.new(given.outputs["Shader"], mix.inputs[1])
    links.new(emit.outputs["Emission"], mix.inputs[2])
    links.new(mix.outputs["Shader"], result.inputs["Shader"])
    for node, x, y in ((given, -500, 0), (colour, -500, -150), (shown, -500, 200), (emit, -250, -150), (mix, 0, 0),
                       (result, 200, 0)):
        node.location = (x, y)
    return tree


def _is_result_node(node):
    return node.type == "GROUP" and node.node_tree is not None and node.node_tree.name.startswith(RESULT_GROUP + ":")


def _install(mat, group):
    """ohm's group between each Material Output's Surface and what fed it
    (nothing else of the material changes; a material without nodes gets
    them turned on, which removal turns off again)."""
    enabled = not mat.use_nodes
    mat.use_nodes = True
    nt = mat.node_tree
    for out in [n for n in nt.nodes if n.type == "OUTPUT_MATERIAL"]:
        surface = out.inputs["Surface"]
        fed = surface.links[0].from_node if surface.is_linked else None
        if fed is not None and _is_result_node(fed):
            fed.node_tree = group
            continue
        node = nt.nodes.new("ShaderNodeGroup")
        node.node_tree, node.label = group, RESULT_GROUP
        node[ENABLED_NODES] = int(enabled)
        node.location = (out.location.x, out.location.y + 180)
        if fed is not None:
            nt.links.new(surface.links[0].from_socket, node.inputs["Shader"])
        nt.links.new(node.outputs["Shader"], surface)


def _uninstall(mat):
    """ohm's group nodes out of the material, their input linked back to
    the output they fed: the material as it was."""
    if mat.node_tree is None:
        return
    nt = mat.node_tree
    for node in [n for n in nt.nodes if _is_result_node(n)]:
        given = node.inputs["Shader"].links[0].from_socket if node.inputs["Shader"].is_linked else None
        fed = [link.to_socket for link in node.outputs["Shader"].links]
        enabled = node.get(ENABLED_NODES, 0)
        nt.nodes.remove(node)
        for socket in fed:
            if given is not None:
                nt.links.new(given, socket)
        if enabled:
            mat.use_nodes = False


def _own_material(obj, group, added_slot):
    """ohm's material for an object (or slot) with none: the group over a
    grey diffuse surface, Blender's look for a face without material, which
    shows when the result is hidden."""
    import bpy
    mat = bpy.data.materials.new("ohm " + obj.name)
    mat[OWN_MATERIAL], mat[ADDED_SLOT] = 1, int(added_slot)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out, diffuse = nt.nodes.new("ShaderNodeOutputMaterial"), nt.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    diffuse.location, out.location = (-300, 0), (200, 0)
    nt.links.new(diffuse.outputs["BSDF"], out.inputs["Surface"])
    _install(mat, group)
    return mat


def show_result(obj, attribute):
    """Make the colour attribute visible without wiring and without
    replacing anything: ohm's node group enters each of the object's
    materials between its output and the artist's surface shader; an object
    or slot with no material gets ohm's own; the object's RESULT_SHOWN is 1.
    The attribute is made active, and the 3D views' solid shading coloured
    by it."""
    import bpy
    group = _result_group(attribute)
    slots = obj.material_slots
    if not slots:
        obj.data.materials.append(_own_material(obj, group, True))
    for slot in slots:
        if slot.material is None:
            slot.material = _own_material(obj, group, False)
        else:
            _install(slot.material, group)
    set_result_shown(obj, True)
    me = obj.data
    if attribute in me.color_attributes:
        me.color_attributes.active_color = me.color_attributes[attribute]
    for screen in bpy.data.screens:
        for area in screen.areas:
            if area.type == "VIEW_3D":
                for space in area.spaces:
                    if space.type == "VIEW_3D":  # "Attribute" in the menu; "VERTEX" to the API in 3.x
                        items = space.shading.bl_rna.properties["color_type"].enum_items.keys()
                        space.shading.color_type = "ATTRIBUTE" if "ATTRIBUTE" in items else "VERTEX"


def set_result_shown(obj, shown):
    """Show result on or off: the property ohm's group reads (renders and
    the viewport follow at once)."""
    obj[RESULT_SHOWN] = 1.0 if shown else 0.0
    obj.update_tag()


def has_result(obj, attribute):
    """Whether ohm's result is in the object: shown, its frames, or its attribute."""
    return RESULT_SHOWN in obj.keys() or obj.modifiers.get(FRAMES_MODIFIER) is not None or \
        attribute in obj.data.attributes


def remove_result(obj, attribute):
    """Everything Show result and Bake put into the .blend for this object,
    removed: ohm's group from the materials (their links as before), ohm's
    own material and the slot it added, the frames modifier and its node
    group, the colour attribute and a bake's per-frame ones, the volume
    object and its material, RESULT_SHOWN.  Files on disk stay."""
    import bpy
    slots = obj.material_slots
    for index in reversed(range(len(slots))):
        mat = slots[index].material
        if mat is not None and mat.get(OWN_MATERIAL):
            if mat.get(ADDED_SLOT) and index == len(slots) - 1 and slots[index].link == "DATA":
                obj.data.materials.pop(index=index)
            else:
                slots[index].material = None
            if mat.users == 0:
                bpy.data.materials.remove(mat)
        elif mat is not None:
            _uninstall(mat)
    drop_frames(obj)
    me = obj.data
    frame_attribute = re.compile(re.escape(attribute) + r"(_\d{4})?$")
    for name in [a.name for a in me.attributes if frame_attribute.match(a.name)]:
        me.attributes.remove(me.attributes[name])
    volume = bpy.data.objects.get(volume_name(obj))
    if volume is not None and volume.type == "VOLUME":
        remove_volume(volume)
    mat = bpy.data.materials.get(volume_name(obj))
    if mat is not None and mat.users == 0:
        bpy.data.materials.remove(mat)
    if RESULT_SHOWN in obj.keys():
        del obj[RESULT_SHOWN]
    for tree in [t for t in bpy.data.node_groups if t.name.startswith(RESULT_GROUP + ":") and t.users == 0]:
        bpy.data.node_groups.remove(tree)
    obj.update_tag()


def remove_volume(vobj):
    """A volume object ohm added, with its volume data when nothing else uses it."""
    import bpy
    volume = vobj.data
    bpy.data.objects.remove(vobj)
    if volume.users == 0:
        bpy.data.volumes.remove(volume)


def frame_attribute(attribute, frame):
    """The name of a baked frame's colour attribute."""
    return "%s_%04d" % (attribute, frame)


def show_frames(obj, attribute, frames):
    """A bake renders as it plays: a geometry nodes modifier (the object's
    last) stores, as the colour attribute ohm's group reads, the per-frame
    attribute of the last solved frame at or before the scene's frame (the
    first before it).  Geometry nodes read the frame themselves (Scene
    Time), so F12, an animation render, `blender -b file.blend -a` (without
    the add-on: no Python runs) and the viewport all show the frame's
    result.  frames: the solved frames, ascending."""
    import bpy
    drop_frames(obj)
    tree = bpy.data.node_groups.new("%s: %s" % (FRAMES_GROUP, obj.name), "GeometryNodeTree")
    tree.inputs.new("NodeSocketGeometry", "Geometry")
    tree.outputs.new("NodeSocketGeometry", "Geometry")
    nodes, links = tree.nodes, tree.links
    given, result, time = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput"), nodes.new("GeometryNodeInputSceneTime")
    time.location = (-400, 300)

    def enabled(sockets, kind=None):
        return next(s for s in sockets if s.enabled and (kind is None or s.type == kind))

    shown = None
    for k, f in enumerate(frames):
        read = nodes.new("GeometryNodeInputNamedAttribute")
        read.data_type = "FLOAT_COLOR"
        read.inputs["Name"].default_value = frame_attribute(attribute, f)
        read.location = (200 * k - 200, -200)
        if shown is None:
            shown = enabled(read.outputs)
            continue
        reached = nodes.new("FunctionNodeCompare")
        reached.data_type, reached.operation = "FLOAT", "GREATER_EQUAL"
        links.new(time.outputs["Frame"], reached.inputs[0])
        reached.inputs[1].default_value = f - 1e-3  # a subframe before f still shows the frame before
        pick = nodes.new("GeometryNodeSwitch")
        pick.input_type = "RGBA"
        links.new(reached.outputs[0], enabled(pick.inputs, "BOOLEAN"))
        falses, trues = [s for s in pick.inputs if s.enabled and s.type == "RGBA"]
        links.new(shown, falses)
        links.new(enabled(read.outputs), trues)
        reached.location, pick.location = (200 * k, 150), (200 * k, 0)
        shown = enabled(pick.outputs)
    store = nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type, store.domain = "FLOAT_COLOR", "POINT"
    store.inputs["Name"].default_value = attribute
    links.new(given.outputs["Geometry"], store.inputs["Geometry"])
    links.new(shown, enabled(store.inputs, "RGBA"))
    links.new(store.outputs["Geometry"], result.inputs["Geometry"])
    given.location, store.location, result.location = (-400, 0), (200 * len(frames), 0), (200 * len(frames) + 200, 0)
    mod = obj.modifiers.new(FRAMES_MODIFIER, "NODES")
    mod.node_group = tree


def drop_frames(obj):
    """A bake's frames modifier and its node group, removed (a Solve or Live
    shows its own result; the per-frame attributes stay)."""
    import bpy
    mod = obj.modifiers.get(FRAMES_MODIFIER)
    if mod is None or mod.type != "NODES":
        return
    tree = mod.node_group
    obj.modifiers.remove(mod)
    if tree is not None and tree.name.startswith(FRAMES_GROUP + ":") and tree.users == 0:
        bpy.data.node_groups.remove(tree)


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
