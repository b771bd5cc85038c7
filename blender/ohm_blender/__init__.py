"""ohm for Blender: subsurface scattering solved by ohm's diffusion network
(libohm, bundled in this add-on's lib/), written onto the mesh as a colour
attribute, relit live from one factor, baked over an animation.

Operators (bpy.ops.ohm.*): solve, live (a modal relight loop), bake.  The
panel is Properties > Object > ohm.  See README.md, "For Blender users".
"""
bl_info = {
    "name": "ohm subsurface scattering",
    "author": "the ohm developers",
    "version": (0, 2, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Object > ohm",
    "description": "Heterogeneous subsurface scattering by factor-once diffusion: solve, live relight, bake",
    "category": "Render",
}

if "bpy" in locals():  # re-registration from Blender's add-on reload
    import importlib
    from . import settings, bridge, session, operators, ui
    for m in (settings, bridge, session, operators, ui):
        importlib.reload(m)
else:
    from . import settings, bridge, session, operators, ui  # noqa: F401

import bpy  # noqa: E402

classes = (settings.OhmSettings,) + operators.classes + ui.classes


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.ohm = bpy.props.PointerProperty(type=settings.OhmSettings)


def unregister():
    session.close_all()
    del bpy.types.Object.ohm
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
