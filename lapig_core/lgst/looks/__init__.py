"""Differentiable looks beside the neural styles: media (posterise, line art, woodblock, halftone, mosaic,
neon, ...), moods (night, dusk, ...), textures (paper, canvas) and palettes from named colours.

Each look is a Stage whose parameters PSA moves; the catalog says what each looks like.
"""
from .catalog import BY_NAME, LOOKS, MEDIA, MOODS, TEXTURES, Look, palette_stage
from .stage import Stage

__all__ = ["BY_NAME", "LOOKS", "MEDIA", "MOODS", "TEXTURES", "Look", "Stage", "palette_stage"]
