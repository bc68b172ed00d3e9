"""Build and validate the extension zip with Blender's own extension CLI (shipped in the bpy wheel)."""
from __future__ import annotations

import glob
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def blender_ext_cli() -> str:
    import bpy

    found = glob.glob(os.path.join(bpy.utils.resource_path("LOCAL"), "scripts", "addons_core", "bl_pkg",
                                   "cli", "blender_ext.py"))
    if not found:
        raise OSError("Blender's extension CLI (blender_ext.py) was not found in the bpy package")
    return found[0]


def tracked_files(root: str = ROOT) -> list[str]:
    """The files git tracks (as they are in the working tree): a stray .blend, its data folder or
    an output left in the checkout must never reach the zip."""
    try:
        listed = subprocess.run(["git", "-C", root, "ls-files", "-z", "--cached"], check=True,
                                capture_output=True).stdout
    except (OSError, subprocess.CalledProcessError) as exc:
        raise OSError(f"the extension is built from the files git tracks, and {root} is not a git "
                      f"checkout ({exc})") from None
    names = [n for n in listed.decode("utf-8").split("\0") if n]
    return [n for n in names if os.path.isfile(os.path.join(root, n))]  # deleted but not committed: skip


def copy_tracked_files(staging: str, root: str = ROOT) -> None:
    """The git-tracked files of the checkout, copied into staging as they are in the working tree."""
    for name in tracked_files(root):
        target = os.path.join(staging, name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copy2(os.path.join(root, name), target)


def build_extension(out_dir: str, root: str = ROOT) -> str:
    """Build the zip from the git-tracked files into out_dir, validate it, return its path.

    The manifest's [build] paths_exclude_pattern still applies (tests, tools, benchmark weights)."""
    os.makedirs(out_dir, exist_ok=True)
    cli = blender_ext_cli()
    with tempfile.TemporaryDirectory(prefix="lapig_build_") as staging:
        copy_tracked_files(staging, root)
        subprocess.run([sys.executable, cli, "build", "--source-dir", staging, "--output-dir", out_dir],
                       check=True, capture_output=True, text=True)
    zips = sorted(glob.glob(os.path.join(out_dir, "lapig-*.zip")), key=os.path.getmtime)
    if not zips:
        raise OSError(f"the extension build wrote no zip into {out_dir}")
    return validate_zip(zips[-1])


def validate_zip(path: str) -> str:
    """Blender's own check of a built zip (manifest, layout, wheels); OSError with its words if it fails."""
    result = subprocess.run([sys.executable, blender_ext_cli(), "validate", path], capture_output=True, text=True)
    if result.returncode != 0 or "FATAL" in result.stdout + result.stderr:
        raise OSError(f"the extension zip does not validate: {result.stdout}{result.stderr}")
    return path
