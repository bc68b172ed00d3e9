"""What the installed zip carries, for the preferences (no bpy).

A per-platform zip (tools/bundle.py) holds `lapig_addon/bundle.json`: its platform, its Python, the
wheels Blender unpacked from it, and the packages it could not carry with the reason and the next step.
A source checkout or the zip without wheels has no such file: its packages come from Blender's Python.
"""
from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass

BUNDLE_FILE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bundle.json")


@dataclass
class StatusLine:
    icon: str  # a Blender icon name; the command line ignores it
    text: str


def read_bundle(path: str = BUNDLE_FILE) -> dict | None:
    """The zip's bundle.json, or None where there is none (or it is unreadable: the dependency list
    below it still says what is found)."""
    try:
        with open(path) as f:
            info = json.load(f)
    except (OSError, ValueError):
        return None
    return info if isinstance(info, dict) else None


# the zips there are, by the Python they are for (tools/bundle.py's PYTHON_LINES)
ZIP_PYTHONS = ("3.11", "3.13")


def right_zip(python_version: tuple) -> str:
    """Which zip fits a Blender that runs this Python: named by Python, since a distribution's Blender 4.x
    may run Python 3.13 and official 4.2 to 5.0 run 3.11."""
    here = "%d.%d" % python_version[:2]
    if here in ZIP_PYTHONS:
        return f"install the zip for Python {here} (lapig-<version>-<platform>-py{here.replace('.', '')}.zip)"
    return (f"no zip is built for Python {here} (there are zips for Python {' and '.join(ZIP_PYTHONS)}): "
            f"install the zip without wheels and its packages into Blender's Python")


def bundle_lines(info: dict | None, python_version: tuple = sys.version_info[:2]) -> list[StatusLine]:
    if info is None:
        return [StatusLine("INFO", "No bundled wheels (a source checkout or the zip without them): "
                                   "the packages come from Blender's Python")]
    here = "%d.%d" % python_version[:2]
    lines = [StatusLine("PACKAGE", f"This zip carries {len(info.get('bundled', []))} wheels for "
                                   f"{info.get('platform', '?')}, Python {info.get('python', '?')}")]
    if info.get("minimum_os"):
        lines.append(StatusLine("INFO", f"Its wheels need {info['minimum_os']} or later"))
    if info.get("python") and info["python"] != here:
        lines.append(StatusLine("ERROR", f"This Blender runs Python {here}, so Blender skipped those wheels: "
                                         f"{right_zip(python_version)}"))
    for missing in info.get("not_bundled", []):
        lines.append(StatusLine("ERROR", f"{missing.get('package')} is not in this zip: {missing.get('reason')}"))
        lines.append(StatusLine("BLANK1", f"Next: {missing.get('next_step')}"))
    return lines
