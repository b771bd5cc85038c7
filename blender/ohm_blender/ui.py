"""The panel: Properties > Object > ohm."""
import textwrap

import bpy

from . import bridge, operators, session


# Characters per line of a warning in the panel.
WRAP_CHARACTERS = 70


class OHM_PT_object(bpy.types.Panel):
    bl_label = "ohm subsurface scattering"
    bl_idname = "OBJECT_PT_ohm"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return context.active_object is not None and context.active_object.type == "MESH"

    def draw(self, context):
        obj = context.active_object
        st = obj.ohm
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column()
        col.prop(st, "material")
        if st.material == "PRESET":
            col.prop(st, "preset")
        elif st.material == "COEFFICIENTS":
            col.prop(st, "sigma_a")
            col.prop(st, "sigma_s")
            col.prop(st, "eta")
        else:
            col.prop(st, "volume_path")
            col.prop(st, "transfer_path")
        col.separator()
        col.prop(st, "grid")
        col.prop(st, "dim" if st.grid == "DIM" else "error")
        col.prop(st, "boundary")
        col.prop(st, "solver")
        if st.solver in ("mg", "auto"):
            col.prop(st, "device")
        col.prop(st, "shadows")
        if context.scene.world is not None:
            col.prop(context.scene.world, "ohm_light")
        col.prop(st, "max_memory_fraction")
        col.separator()
        col.prop(st, "exposure")
        col.prop(st, "attribute")
        col.prop(st, "show_result")
        col.prop(st, "make_volume")
        col.prop(st, "directory")
        s = session.get(obj)
        if st.make_volume or (s is not None and "baked" in s.status):
            col.label(text="→ " + operators.output_directory(obj))
        row = layout.row(align=True)
        if s is not None and s.job is not None:
            row.operator("ohm.cancel", icon="CANCEL")
        else:
            row.operator("ohm.solve")
            row.operator("ohm.live")
            row.operator("ohm.bake")
            if bridge.has_result(obj, st.attribute):
                layout.operator("ohm.remove", icon="X")
        if s is None:
            return
        box = layout.box()
        if s.status:
            box.label(text=s.status)
        if s.solver_note and s.job is None:
            box.label(text=s.solver_note)
        if s.result is not None and s.job is None:
            box.label(text="exitance × %.4g = colour (W/mm² per W of light)" % (s.exposure or 0))
        for text in s.warnings:  # wrapped: Blender's labels cut long lines in the middle
            col = box.column(align=True)
            for i, line in enumerate(textwrap.wrap(text, WRAP_CHARACTERS)):
                col.label(text=line, icon="ERROR" if i == 0 else "BLANK1")


classes = (OHM_PT_object,)
