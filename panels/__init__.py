"""The 'LAPIG' tab in the 3D viewport's sidebar, in the order the work is done."""
from . import light_panel, main_panel, show_panel


def register():
    main_panel.register()
    light_panel.register()
    show_panel.register()


def unregister():
    show_panel.unregister()
    light_panel.unregister()
    main_panel.unregister()
