"""The panel: Properties > Object > ohm."""
import bpy


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
        st = context.active_object.ohm
        col = self.layout.column()
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
        col.prop(st, "shadows")
        col.separator()
        col.prop(st, "exposure")
        col.prop(st, "attribute")
        col.prop(st, "make_volume")
        col.prop(st, "directory")
        row = col.row(align=True)
        row.operator("ohm.solve")
        row.operator("ohm.live")
        row.operator("ohm.bake")
        if st.status:
            col.label(text=st.status)
        if st.updates_per_second > 0:
            col.label(text="live: %.1f updates/s, %d factorizations" % (st.updates_per_second, st.factorizations))


classes = (OHM_PT_object,)
