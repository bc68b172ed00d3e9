"""A stage's way for the rig's model strategy (Rig.strategy): each stage names its two ways once, and the rig's
strategy picks one. No stage asks how many projectors there are."""
from __future__ import annotations

import importlib

from .state import JOINT, PROJECTOR_SPACE


def chosen_way(rig, projector_space, joint):
    """The way for `rig`'s strategy. A way given as 'module:Name' (the module relative to lapig_addon.services,
    e.g. 'render.render_joint') is imported only when it is chosen, so one projector's steps never load the joint
    model's code."""
    way = {PROJECTOR_SPACE: projector_space, JOINT: joint}[rig.strategy]
    if isinstance(way, str):
        module, name = way.split(":")
        way = getattr(importlib.import_module(f".{module}", __package__), name)
    return way
