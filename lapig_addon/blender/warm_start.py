"""Start the session's warm-up (services/warmup) when the artist first uses the add-on: its panel drawn or one of
its jobs started, in Blender's UI only (scripts, tests and headless runs load what they need when they need it)."""
from __future__ import annotations

import bpy

from ...lapig_core.common.deps import missing_required
from ..services import warmup


def on_first_use() -> None:
    """Cheap after the first call (a flag): safe in a panel's draw()."""
    if warmup.warmup_state()["running"] or warmup.warmup_state()["seconds"] is not None:
        return
    if bpy.app.background or missing_required():  # no UI to keep waiting, or torch missing (the panel says so)
        return
    warmup.start_warmup()
