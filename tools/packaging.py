"""Build and validate the extension zip with Blender's own extension CLI (shipped in the bpy wheel)."""
from __future__ import annotations

import glob
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def blender_ext_cli() -> str:
    import bpy

    found = glob.glob(os.path.join(bpy.utils.resource_path("LOCAL"), "scripts", "addons_core", "bl_pkg",
                                   "cli", "blender_ext.py"))
    if not found:
        raise OSError("Blender's extension CLI (blender_ext.py) was not found in the bpy package")
    return found[0]


def build_extension(out_dir: str) -> str:
    """Build the zip from the repository root into out_dir, validate it, return its path."""
    os.makedirs(out_dir, exist_ok=True)
    cli = blender_ext_cli()
    subprocess.run([sys.executable, cli, "build", "--source-dir", ROOT, "--output-dir", out_dir],
                   check=True, capture_output=True, text=True)
    zips = sorted(glob.glob(os.path.join(out_dir, "lapig-*.zip")), key=os.path.getmtime)
    if not zips:
        raise OSError(f"the extension build wrote no zip into {out_dir}")
    result = subprocess.run([sys.executable, cli, "validate", zips[-1]], capture_output=True, text=True)
    if result.returncode != 0 or "FATAL" in result.stdout + result.stderr:
        raise OSError(f"the extension zip does not validate: {result.stdout}{result.stderr}")
    return zips[-1]
