"""The panel: Properties > Object > ohm."""
import textwrap

import bpy

from . import bridge, messages, operators, session


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
        col.prop(st, "scale")
        mm = bridge.mm_per_unit(context.scene, obj)
        split = col.split(factor=0.4)  # under the field, as use_property_split places it
        split.label(text="")
        split.label(text="%s1 unit = %s: %s is %s across" % (
            "Auto: " if st.scale <= 0 else "", messages.length_text(mm), obj.name,
            messages.length_text(mm * max(obj.dimensions))))
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
        col.prop(st, "max_memory")
        col.separator()
        row = col.row(align=True)
        row.prop(st, "exposure")
        row.operator("ohm.auto_exposure", text="Auto")
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
        if s.status and not any(note.text == s.status for note in s.notes):  # a failure's is its first note
            box.label(text=s.status)
        if s.solver_note and s.job is None:
            box.label(text=s.solver_note)
        if s.result is not None and s.job is None and not st.exposure and s.auto_exposure:
            box.label(text="Exposure %.4g (automatic, chosen at the first result)" % s.auto_exposure)
        for note in s.notes:  # wrapped: Blender's labels cut long lines in the middle
            col = box.column(align=True)
            icon = {"ERROR": "CANCEL", "WARNING": "ERROR"}.get(note.level, "INFO")
            for i, line in enumerate(textwrap.wrap(note.text, WRAP_CHARACTERS)):
                col.label(text=line, icon=icon if i == 0 else "BLANK1")
            if note.details:  # the figures, in physics terms, greyed
                sub = col.column(align=True)
                sub.enabled = False
                for line in textwrap.wrap("details: " + note.details, WRAP_CHARACTERS):
                    sub.label(text=line, icon="BLANK1")


classes = (OHM_PT_object,)
