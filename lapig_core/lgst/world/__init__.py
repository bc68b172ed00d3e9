"""Looks of the world: procedural, differentiable generators of materials, plants, water, fire, sky, weather and
made things (issue 50), composed from the prompt's words (compose.py) into a look stage PSA can move.

    noise.py     gradient noise, fBm, ridged, turbulence, domain warping
    cells.py     Worley (cellular) noise: F1, F2, F2-F1, the nearest cell's id
    tilings.py   bricks, hexagons, checkers, weave, planks, circuit traces, scales
    shapes.py    signed-distance shapes scattered on a jittered grid: leaves, petals, drops, bubbles, snowflakes
    growth.py    reaction-diffusion (Gray-Scott): lichen, coral, spots and mazes
    ramps.py     colour ramps and the blackbody ramp (fire, embers, glow)
    patterns.py  the scalar fields a material is made of, by name, from the modules above
    materials.toml  the materials: a pattern, its parameters, a colour ramp, the words it answers to
    catalog.py   reads materials.toml (data only: names and numbers, never code)
    compose.py   prompt words -> a composition (a base, overlays, weathering, modifiers)
    stage.py     the composition as a look Stage (its colours, contrast, scale and coverage are PSA's theta)

Coordinates are shares of the image's longer side, so a look has the same cells at the working frame and at the
projector's native frame. Everything is torch and differentiable in the coordinates and the colours; the
reaction-diffusion pattern is grown once (no gradient) and sampled.
"""
