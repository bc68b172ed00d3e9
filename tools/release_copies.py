"""Make the saved copies of what a release writes: a .blend of one projector and one of two, each with its
capture, a result and the exported files, made by that release's own code (issue 51 item 3). The tests
(tests/blender/test_release_copies_in_blender.py, tests/core/test_release_copies.py) open them with the code of today.

    git worktree add /tmp/release <commit>
    .venv/bin/python tools/release_copies.py --release /tmp/release --out tests/data/release_<version>

Everything runs in the release's checkout: its package is loaded as `lapig`, as Blender loads the extension, and
its command line makes the capture, the look and the export. Sizes are tiny (camera 80x60, projectors 64x48), so
the copies stay small in the repository.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import pathlib
import shutil
import subprocess
import sys

PROMPT = "Make it a stained glass artwork"


def load_release(root: pathlib.Path):
    spec = importlib.util.spec_from_file_location("lapig", root / "__init__.py", submodule_search_locations=[str(root)])
    package = importlib.util.module_from_spec(spec)
    sys.modules["lapig"] = package
    spec.loader.exec_module(package)
    return package


def cli(root, *args):
    proc = subprocess.run([sys.executable, "-m", "lapig_addon", *args], cwd=root, capture_output=True, text=True,
                          timeout=1200)
    if proc.returncode:
        raise SystemExit(f"{' '.join(args[:1])} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout[proc.stdout.index("{"):])


def build_blend(folder: pathlib.Path, projectors: int):
    import bpy

    from lapig.lapig_addon.cli import headless

    folder.mkdir(parents=True, exist_ok=True)
    scene, projector, camera, target = headless.build_demo_setup("panel", "sakura", folder=str(folder),
                                                                 camera_resolution=(80, 60),
                                                                 projector_resolution=(64, 48))
    s = scene.lapig
    s.train_count, s.test_count, s.working_size = 4, 0, 64
    s.prompt = PROMPT
    if projectors == 2:
        assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    blend = folder / "wall.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), compress=True)
    return blend


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--release", required=True, type=pathlib.Path)
    parser.add_argument("--out", required=True, type=pathlib.Path)
    args = parser.parse_args()
    root = args.release.resolve()
    load_release(root)
    from lapig.lapig_addon.blender import addon

    addon.register()
    made = {"release": subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True,
                                      text=True).stdout.strip(), "prompt": PROMPT, "copies": {}}
    out = args.out.resolve()
    if out.exists():
        shutil.rmtree(out)
    for name, count in (("one", 1), ("two", 2)):
        folder = out / name
        blend = str(build_blend(folder, count))
        capture = cli(root, "capture", "--blend", blend, "--save", "--samples", "4")
        stylized = cli(root, "stylize", "--blend", blend, "--prompt", PROMPT, "--save")
        export = folder / "export"
        export.mkdir()
        extra = ["--mpcdi", str(export / "rig.mpcdi")] if count == 2 else []
        cli(root, "export", "--blend", blend, "--out", str(export / "projector.png"), *extra)
        made["copies"][name] = {"projectors": count, "capture": capture.get("capture") or capture.get("setup"),
                                "result": stylized.get("result"),
                                "exported": sorted(p.name for p in export.iterdir())}
    # the folders are recorded relative to the .blend: make the record's paths relative too
    text = json.dumps(made, indent=1).replace(str(out) + "/", "")
    (out / "MADE_BY.json").write_text(text + "\n", encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
