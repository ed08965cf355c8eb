"""A stand-in for Blender's ``UILayout`` that records what a panel draws, for the panel tests:
the properties (by name, checked to exist on their data), the operators (checked to be
registered), the labels (``"label: TEXT"``) and the UILists, in the order drawn; icons are
checked against the running Blender's names (a wrong name raises only in a real draw). Other
layout calls (menus, separators, …) draw nothing the tests look at."""

import bpy


def check_icon(kw):
    """Fail on an icon name the running Blender does not know."""
    if "icon" in kw:
        icons = bpy.types.UILayout.bl_rna.functions["label"].parameters["icon"].enum_items
        assert kw["icon"] in {i.identifier for i in icons}, kw["icon"]


class Layout:
    """Records into ``log`` (a list shared with every sub-layout)."""

    def __init__(self, log):
        self.log = log
        self.use_property_split = self.use_property_decorate = False
        self.active = True
        self.scale_y = 1.0

    def prop(self, data, name, **_kw):
        assert hasattr(data, name), name
        self.log.append(name)

    def _child(self, *_a, **_kw):
        return Layout(self.log)

    row = column = box = split = _child

    def label(self, text="", **kw):
        check_icon(kw)
        self.log.append("label: " + text)

    def template_list(self, list_id, _name, data, prop, active_data, active_prop, **_kw):
        assert list_id in dir(bpy.types) and hasattr(data, prop)
        assert hasattr(active_data, active_prop)
        self.log.append(list_id)

    def operator(self, idname, **kw):
        check_icon(kw)
        module, name = idname.split(".")
        assert hasattr(getattr(bpy.ops, module), name), idname
        self.log.append(idname)
        return type("Props", (), {})()

    def operator_menu_enum(self, idname, _prop, **kw):
        return self.operator(idname, **kw)

    def __getattr__(self, name):  # other layout calls (separators, menus) draw no row
        if name.startswith("__"):
            raise AttributeError(name)
        return lambda *_a, **_kw: Layout(self.log)


def drawn(panel_class, context=None):
    """What ``panel_class.draw`` draws in ``context`` (default: ``bpy.context``)."""
    log = []
    panel_class.draw(type("P", (), {"layout": Layout(log)})(), context or bpy.context)
    return log
