"""LAPIG core: the bpy-free library (networks, losses, PSA, LGST, structured light, datasets, metrics).

Nothing in this package may import bpy: it is tested and used without Blender.
"""
