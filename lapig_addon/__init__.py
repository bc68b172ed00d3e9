"""The Blender side of LAPIG: properties, rig building, captures, jobs and the command line.

Kept free of imports at package level so that `python -m lapig_addon` can bootstrap the
extension package first (see __main__.py).
"""
