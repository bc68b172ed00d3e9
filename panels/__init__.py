"""The 'LAPIG' tab in the 3D viewport's sidebar, in the order the work is done."""
from . import light_panel, main_panel


def register():
    main_panel.register()
    light_panel.register()


def unregister():
    light_panel.unregister()
    main_panel.unregister()
