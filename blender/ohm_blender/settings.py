"""What the panel sets, per object (bpy.types.Object.ohm): settings only.
Runtime state (status, warnings, rates) lives in the session, not in the
.blend."""
import bpy

from . import bridge, session

PRESETS = ("apple", "chicken1", "chicken2", "cream", "ketchup", "marble", "potato", "skimmilk", "skin1", "skin2",
           "spectralon", "wholemilk")


def _recolour(self, context):
    """A new exposure or attribute recolours the current result at once (no solve)."""
    obj = self.id_data
    s = session.get(obj)
    if s is not None:
        s.recolour(obj)
        bridge.set_volume_exposure(bpy.data.materials.get(bridge.volume_name(obj)), s.exposure)


def _show_result(self, context):
    """Show result on: ohm's group in the materials (when there is a result
    to show); off: the artist's shaders render, ohm's group stays, passing
    them through."""
    obj = self.id_data
    if self.show_result and self.attribute in obj.data.attributes:
        bridge.show_result(obj, self.attribute)
    elif not self.show_result and bridge.RESULT_SHOWN in obj.keys():
        bridge.set_result_shown(obj, False)


class OhmSettings(bpy.types.PropertyGroup):
    material: bpy.props.EnumProperty(
        name="Material", default="PRESET",
        items=[("PRESET", "Measured preset", "Jensen et al. 2001's measured materials"),
               ("COEFFICIENTS", "Coefficients", "sigma_a, sigma_s' per R, G, B and the index"),
               ("VOLUME", "Density volume", "a CT/MRI volume through a transfer function")])
    preset: bpy.props.EnumProperty(name="Preset", default="marble", items=[(p, p, "") for p in PRESETS])
    sigma_a: bpy.props.FloatVectorProperty(name="σa (1/mm)", size=3, min=0.0, default=(0.0021, 0.0041, 0.0071),
                                           precision=5)
    sigma_s: bpy.props.FloatVectorProperty(name="σs′ (1/mm)", size=3, min=1e-9, default=(2.19, 2.62, 3.00),
                                           precision=4)
    eta: bpy.props.FloatProperty(name="Index η", min=1.0, max=3.0, default=1.3)
    volume_path: bpy.props.StringProperty(name="Volume", subtype="FILE_PATH",
                                          description=".vdb, .nii(.gz) or .raw(.gz) density volume")
    transfer_path: bpy.props.StringProperty(name="Transfer function", subtype="FILE_PATH",
                                            description="density -> coefficients (docs/transfer-functions.md)")
    grid: bpy.props.EnumProperty(name="Grid", default="DIM",
                                 items=[("DIM", "Cells across", "cells along the longest axis"),
                                        ("ERROR", "Accuracy target", "the relative exitance error ohm aims for")])
    dim: bpy.props.IntProperty(name="Cells", min=4, max=1024, default=48,
                               description="cells along the longest axis; a setting that would not fit in the "
                                           "memory allowed is refused with the figure it needs")
    error: bpy.props.FloatProperty(name="Error", min=0.001, max=0.5, default=0.05)
    boundary: bpy.props.EnumProperty(name="Boundary", default="robin",
                                     items=[("robin", "Fresnel (robin)", "light leaves through the surface"),
                                            ("neumann", "Closed (neumann)", "the paper's: no light leaves"),
                                            ("dirichlet", "Zero (dirichlet)", "fluence 0 at the surface")])
    solver: bpy.props.EnumProperty(name="Solver", default="auto",
                                   items=[("auto", "Auto", "the library's choice by memory and predicted time over a "
                                           "Live session's solves: the factor where it fits and pays, multigrid beyond "
                                           "(docs/blender-addon.md)"),
                                          ("direct", "Direct (factor once)", "Cholesky factor reused for every light"),
                                          ("mg", "Multigrid", "geometric multigrid: large grids, low memory, "
                                           "a quick first solve"),
                                          ("cg", "Conjugate gradients", "low memory"),
                                          ("amg", "Algebraic multigrid", "PETSc + hypre, for runs under mpirun")])
    device: bpy.props.EnumProperty(
        name="Device", default="host",
        description="where Multigrid solves (also when Auto chooses it): the hierarchy stays on the device for "
                    "Live relight and Bake ('ohm devices' lists them)",
        items=[("host", "This computer's cores", "no OpenCL"),
               ("auto", "GPU when there is one", "the first OpenCL GPU with double precision, else the cores"),
               ("gpu", "GPU", "the first OpenCL GPU with double precision; refused when there is none"),
               ("cpu", "OpenCL CPU", "an OpenCL CPU device (PoCL): the same kernels as a GPU's")])
    shadows: bpy.props.BoolProperty(name="Shadows", default=True, description="shadow rays against the mesh")
    max_memory: bpy.props.IntProperty(
        name="Memory", min=5, max=90, default=50, subtype="PERCENTAGE",
        description="the share of the memory available when a solve starts that it may take; a larger setting is "
                    "refused before anything large is allocated, leaving Blender the rest")
    # Memory as a fraction, for the code that computes with it (not stored, not shown)
    max_memory_fraction: bpy.props.FloatProperty(
        min=0.05, max=0.9, get=lambda self: self.max_memory / 100.0,
        set=lambda self, value: setattr(self, "max_memory", round(100.0 * value)))
    scale: bpy.props.FloatProperty(
        name="Scale", min=0.0, default=0.0, precision=4, step=10,
        description="millimetres of material per scene unit, as Cycles' Subsurface Scale sets how far light "
                    "spreads: a smaller Scale makes the object smaller to the light, so more translucent.  0: Auto, "
                    "the scene's Unit Scale where it was changed (0.001: 1 unit = 1 mm), else 100 mm per unit "
                    "(Blender's default units, where a new Suzanne is 2.7 units across: a 27 cm head)")
    exposure: bpy.props.FloatProperty(
        name="Exposure", min=0.0, default=0.0, update=_recolour,
        description="brightness of the result: colour = light leaving the surface (W/mm² per W of light) × "
                    "Exposure.  0: automatic, chosen from the first result (its brightest 1% white) and then kept, "
                    "so a dimmer light shows dimmer; Auto exposure chooses again.  Recolours at once")
    attribute: bpy.props.StringProperty(name="Attribute", default="ohm_exitance", update=_recolour)
    show_result: bpy.props.BoolProperty(
        name="Show result", default=True, update=_show_result,
        description="show the colour attribute in renders (Cycles and EEVEE) through ohm's node group, which enters "
                    "the object's own materials (an object without one gets ohm's), and colour the viewport by it; "
                    "off: the materials render as the artist made them")
    make_volume: bpy.props.BoolProperty(name="Volume object", default=False,
                                        description="also write a .vdb and add it as an emitting volume")
    directory: bpy.props.StringProperty(name="Output", subtype="DIR_PATH", default="//ohm/")


def world_light_property():
    """World.ohm_light: whether the World lights the object as ohm's
    environment light (its colour, or its Environment Texture's image; see
    bridge.world_light).  Off by default: Blender's default World is a dim
    grey that would add light to every scene made before."""
    return bpy.props.BoolProperty(
        name="World lights it", default=False,
        description="the World's colour (or its Environment Texture image, .hdr or .exr) becomes ohm's environment "
                    "light: each face lit by the sky it sees past the object itself")
