"""What the installed zip carries, for the preferences (no bpy).

A per-platform zip (tools/bundle.py) holds `lapig_addon/bundle.json`: its platform, its Python, the
wheels Blender unpacked from it, and the packages it could not carry with the reason and the next step.
A source checkout or the zip without wheels has no such file: its packages come from Blender's Python.
"""
from __future__ import annotations

import json
import os
import re
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


def running_numpy() -> str | None:
    """The numpy of the Python that Blender runs (Blender's own, or a distribution's system numpy)."""
    try:
        import numpy
    except ImportError:
        return None
    return numpy.__version__


def _release(text: str) -> tuple:
    """'2.2.4' -> (2, 2, 4); '2' -> (2, 0, 0)."""
    parts = [int(part) for part in re.findall(r"\d+", text.split("+")[0])[:3]]
    return tuple(parts + [0] * (3 - len(parts)))


def numpy_fits(requirement: str, version: str) -> bool:
    """Whether numpy `version` meets a requirement such as 'numpy>=2,<2.3' (bundle.json's; >= and < only)."""
    have = _release(version)
    for op, bound in re.findall(r"(>=|<)\s*([\d.]+)", requirement):
        if (have < _release(bound)) if op == ">=" else (have >= _release(bound)):
            return False
    return True


def bundle_lines(info: dict | None, python_version: tuple = sys.version_info[:2],
                 numpy_version: str | None = None) -> list[StatusLine]:
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
    numpy_version = numpy_version or running_numpy()
    if info.get("numpy") and numpy_version and not numpy_fits(info["numpy"], numpy_version):
        # a distribution's Blender brings its system numpy: OpenCV's compiled module needs the numpy it was
        # built for (numpy 1 for the py311 zip, numpy 2 below 2.3 for the py313 zip)
        lines.append(StatusLine("ERROR", f"This Blender's numpy is {numpy_version}, and this zip's OpenCV needs "
                                         f"{info['numpy']}, so it will not load: install an OpenCV built for "
                                         f"numpy {numpy_version} (opencv-contrib-python-headless) into "
                                         f"Blender's Python"))
    for missing in info.get("not_bundled", []):
        lines.append(StatusLine("ERROR", f"{missing.get('package')} is not in this zip: {missing.get('reason')}"))
        lines.append(StatusLine("BLANK1", f"Next: {missing.get('next_step')}"))
    return lines
