"""Blender's scene in ohm's terms: units, the mesh as placed, the lights,
and the colour attribute written back.  No state of its own."""
import math

import numpy as np


def mm_per_unit(scene):
    """Millimetres per Blender unit (the scene's unit scale: 1 unit = scale_length m)."""
    return scene.unit_settings.scale_length * 1000.0


def mesh_arrays(obj, mm):
    """The object's mesh as placed in the world, in mm: vertices (n, 3) in
    the mesh's own vertex order (so ohm's per-vertex results map straight
    back onto it), triangles (m, 3)."""
    me = obj.data
    me.calc_loop_triangles()
    co = np.empty(3 * len(me.vertices), dtype=np.float64)
    me.vertices.foreach_get("co", co)
    m = np.array(obj.matrix_world, dtype=np.float64)
    world = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    tris = np.empty(3 * len(me.loop_triangles), dtype=np.int32)
    me.loop_triangles.foreach_get("vertices", tris)
    return world * mm, tris.reshape(-1, 3).astype(np.int64)


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


def scene_lights(scene, mm):
    """Every visible light of the scene, as ohm options."""
    out = []
    for obj in scene.objects:
        if obj.type == "LIGHT" and not obj.hide_render:
            opts = light_options(obj, mm)
            if opts:
                out.append(opts)
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
