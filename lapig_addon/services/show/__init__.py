"""The show: its plan, its source, each projector's writer, the bake and export jobs."""
