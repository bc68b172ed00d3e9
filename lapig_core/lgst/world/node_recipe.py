# SPDX-License-Identifier: GPL-3.0-or-later
"""A world look as a recipe of Blender shader nodes (issue 50, item 4, optional): the base material's pattern as
the nearest texture node (Voronoi for cells and stones, Brick for masonry, Wave for grain and stripes, Checker,
else Noise) with the look's sliders as the node's inputs (Scale, Detail, Roughness, Distortion; the seed as the
4D texture's W), its colour ramp, and a Hue/Saturation node. Plain values: blender/look_nodes builds the node group.

An approximation for the artist to carry on from in the node editor: the torch generators are not node graphs,
and PSA's adaptation is not in it (the projector image is). Plain Python, no torch."""
from __future__ import annotations

from .ramps import fire_colours

VORONOI = {"speckle": "F1", "stones": "DISTANCE_TO_EDGE", "cracks": "DISTANCE_TO_EDGE", "hammered": "F1",
           "embers": "F1", "scales": "F1", "caustics": "DISTANCE_TO_EDGE", "honeycomb": "DISTANCE_TO_EDGE",
           "craters": "F1", "rosettes": "F1", "eyes": "F1"}
WAVE = {"woodgrain": "RINGS", "stripes": "BANDS", "waves": "BANDS", "corrugated": "BANDS", "twill": "BANDS",
        "strata": "BANDS", "veins": "BANDS"}
BRICK = ("masonry",)
CHECKER = ("checker", "tartan")


def texture_of(pattern: str) -> tuple[str, str]:
    """(the node's type, its feature or profile) for a pattern."""
    if pattern in VORONOI:
        return "ShaderNodeTexVoronoi", VORONOI[pattern]
    if pattern in WAVE:
        return "ShaderNodeTexWave", WAVE[pattern]
    if pattern in BRICK:
        return "ShaderNodeTexBrick", ""
    if pattern in CHECKER:
        return "ShaderNodeTexChecker", ""
    return "ShaderNodeTexNoise", ""


def _ramp(colours, blackbody: bool) -> list:
    if blackbody or not colours:  # the torch look's own fire ramp
        colours = fire_colours()
    n = len(colours)
    return [[round(i / max(n - 1, 1), 4), [float(c) for c in rgb] + [1.0]] for i, rgb in enumerate(colours)]


def node_recipe(material, params, colours=None) -> dict:
    """The recipe of `material` (world/catalog.Material, the look's base) drawn with `params`
    (look_parameters.LookParameters); colours: the ramp the look uses (None: the material's own)."""
    node, feature = texture_of(material.pattern)
    scale = float(material.scale) * float(params.scale)
    inputs = {"Scale": round(scale, 4)}
    if node in ("ShaderNodeTexNoise", "ShaderNodeTexWave"):
        inputs.update({"Detail": round(2.0 + 4.0 * min(params.detail, 3.0) / 3.0 * 1.5, 3),
                       "Roughness": round(min(1.0, 0.35 + 0.2 * params.roughness), 3),
                       "Distortion": round(params.distortion * 2.0, 3)})
    if node == "ShaderNodeTexVoronoi":
        inputs.update({"Randomness": 1.0, "Detail": round(min(params.detail, 3.0) * 2.0, 3),
                       "Roughness": round(min(1.0, 0.35 + 0.2 * params.roughness), 3)})
    four_d = node in ("ShaderNodeTexNoise", "ShaderNodeTexVoronoi")
    if four_d:
        inputs["W"] = round(params.seed * 1.618, 4)  # the seed: another slice of the 4D texture
    hue = (0.5 + params.hue / 360.0) % 1.0 if params.hue else 0.5
    own = list(colours) if colours else [list(c) for c in material.colours]
    return {"name": f"LAPIG look: {material.name.replace('_', ' ')}", "texture": node, "feature": feature,
            "dimensions": "4D" if four_d else "", "inputs": inputs,
            "ramp": _ramp(own, material.ramp == "blackbody"),
            "hue": round(hue, 4), "saturation": round(float(params.saturation), 4),
            "pattern": material.pattern, "material": material.name}
