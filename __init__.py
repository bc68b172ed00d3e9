# SPDX-License-Identifier: GPL-3.0-or-later
"""LAPIG: language-guided projector images for projection mapping (Blender extension entry point).

Imports happen inside register() so that the bpy-free library (lapig_core) and the command line
(`python -m lapig_addon`) can load this package without starting Blender's UI parts.
"""


def register():
    from .lapig_addon.blender import addon

    addon.register()


def unregister():
    from .lapig_addon.blender import addon

    addon.unregister()
