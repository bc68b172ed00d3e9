"""The 'LAPIG' tab in the 3D viewport's sidebar, in the order the work is done."""
from . import main_panel


def register():
    main_panel.register()


def unregister():
    main_panel.unregister()
