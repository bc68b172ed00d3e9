"""The add-on's preferences as other modules read them (kept apart from preferences.py, which draws them and
imports the modules that draw into it, so that those can read the preferences without an import cycle)."""
import bpy


def addon_package() -> str:
    return __package__.rsplit(".", 2)[0]  # the extension package, e.g. bl_ext.user_default.lapig


def addon_preferences(context=None):
    """The add-on's preferences, or None where it is registered without being enabled (the bpy module)."""
    context = context or bpy.context
    addon = context.preferences.addons.get(addon_package())
    return addon.preferences if addon and addon.preferences else None


def compute_device() -> str:
    """'auto' or 'cpu' from the preferences ('auto' when the add-on is registered without being enabled, as
    in the bpy module)."""
    prefs = addon_preferences()
    return prefs.device.lower() if prefs is not None else "auto"
