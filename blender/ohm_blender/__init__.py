"""ohm for Blender: subsurface scattering solved by ohm's diffusion network
(libohm, bundled in this add-on's lib/), written onto the mesh as a colour
attribute, relit live from one solver set-up, baked over an animation.

Operators (bpy.ops.ohm.*): solve (in the background when invoked from the
panel: Esc or Cancel stops it), cancel, live (a modal relight loop), bake,
remove (what ohm added to the object's materials and data).  The panel is
Properties > Object > ohm.  See docs/blender-addon.md.
"""
bl_info = {
    "name": "ohm subsurface scattering",
    "author": "the ohm developers",
    "version": (0, 2, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Object > ohm",
    "description": "Heterogeneous subsurface scattering by set-up-once diffusion: solve, live relight, bake",
    "category": "Render",
}

if "bpy" in locals():  # re-registration from Blender's add-on reload
    import importlib
    from . import settings, bridge, messages, session, operators, ui
    for m in (settings, bridge, messages, session, operators, ui):
        importlib.reload(m)
else:
    from . import settings, bridge, messages, session, operators, ui  # noqa: F401

import bpy  # noqa: E402

classes = (settings.OhmSettings,) + operators.classes + ui.classes


@bpy.app.handlers.persistent
def _on_load(_dummy):
    """A file is loaded: every session's object is gone."""
    session.close_all()


@bpy.app.handlers.persistent
def _on_depsgraph(scene, depsgraph=None):
    """An object deleted (or reallocated by an undo): its session is closed;
    an object's geometry or placement changed: its session hashes it anew."""
    session.prune(bpy.data.objects)
    if depsgraph is not None:
        session.mark_geometry(depsgraph)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.ohm = bpy.props.PointerProperty(type=settings.OhmSettings)
    bpy.types.World.ohm_light = settings.world_light_property()
    bpy.app.handlers.load_pre.append(_on_load)
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph)


def unregister():
    for handlers, fn in ((bpy.app.handlers.load_pre, _on_load), (bpy.app.handlers.depsgraph_update_post, _on_depsgraph)):
        if fn in handlers:
            handlers.remove(fn)
    session.close_all()
    del bpy.types.Object.ohm
    del bpy.types.World.ohm_light
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
