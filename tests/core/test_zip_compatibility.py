"""Which Blender accepts which zip, decided by Blender's own code (bpy-free).

Blender's extension code ships in the bpy wheel as plain files (`bl_pkg/cli/blender_ext.py` needs only the
standard library; `bl_pkg/bl_extension_ops.py` needs bpy to import). A zip's Python is not in its manifest:
Blender derives it from the wheels' tags (`python_versions_from_wheels`) and checks it, the platform and the
Blender range with `repository_filter_skip`, composed as `bl_pkg.manifest_compatible_with_wheel_data_or_error`
does when it builds the compatibility cache (addon_utils) that decides whether an installed extension may be
enabled. These functions are the same in bpy 4.2.23, 5.0.1 and 5.3.0 (compared when this was written), so the
bpy 5.0.1 copy of them answers for Blender 4.2 to 5.3 here.
"""
import ast
import builtins
import glob
import importlib.util
import os
import tomllib
from types import SimpleNamespace

import pytest

from lapig.lapig_addon.services.panel import bundle_status
from lapig.tools import bundle

# a zip's wheels as the package index names them (one of each kind: a CPython-only build, an abi3 build, a
# pure-Python wheel, pysdl2-dll's py2.py3 tag)
WHEELS = {
    "py311": ["onnx-1.23.2-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl",
              "opencv_contrib_python_headless-4.11.0.86-cp37-abi3-manylinux_2_17_x86_64.manylinux2014_x86_64.whl",
              "av-18.0.0-cp311-abi3-manylinux_2_28_x86_64.whl", "tqdm-4.70.1-py3-none-any.whl",
              "pysdl2_dll-2.32.10-py2.py3-none-manylinux_2_28_x86_64.whl"],
    "py313": ["onnx-1.23.2-cp313-cp313-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl",
              "opencv_contrib_python_headless-4.12.0.88-cp37-abi3-manylinux_2_17_x86_64.manylinux2014_x86_64.whl",
              "av-18.0.0-cp311-abi3-manylinux_2_28_x86_64.whl", "tqdm-4.70.1-py3-none-any.whl",
              "pysdl2_dll-2.32.10-py2.py3-none-manylinux_2_28_x86_64.whl"],
}
# (Blender, the Python it runs): official 4.2 LTS and 5.0 run 3.11, official 5.3 runs 3.13, Debian trixie's
# Blender 4.3.2 runs the system's Python 3.13.5
BLENDERS = {"4.2.23": (3, 11, 7), "4.3.2 (Debian, Python 3.13)": (3, 13, 5), "5.0.1": (3, 11, 13),
            "5.3.0": (3, 13, 9)}


def _bl_pkg_folder() -> str:
    spec = importlib.util.find_spec("bpy")  # finds the package without importing it
    if spec is None or not spec.submodule_search_locations:
        pytest.skip("the bpy wheel (which carries Blender's extension code) is not installed")
    [folder] = glob.glob(os.path.join(list(spec.submodule_search_locations)[0], "*", "scripts", "addons_core",
                                      "bl_pkg"))
    return folder


@pytest.fixture(scope="module")
def blender_ext():
    path = os.path.join(_bl_pkg_folder(), "cli", "blender_ext.py")
    spec = importlib.util.spec_from_file_location("lapig_test_blender_ext", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _zip_manifest(python_tag: str) -> dict:
    with open(os.path.join(bundle.ROOT, "blender_manifest.toml")) as f:
        text = f.read()
    plan = bundle.plan("linux-x64", python_tag, lock=[])
    return tomllib.loads(bundle._manifest_for(text, plan, WHEELS[python_tag]))


def blender_refusal(blender_ext, manifest: dict, blender: str, python: tuple) -> str | None:
    """Blender's reason for refusing this manifest on linux-x64, or None where it accepts it (the steps of
    `manifest_compatible_with_wheel_data_or_error` and `pkg_manifest_params_compatible_or_error`)."""
    versions = blender_ext.python_versions_from_wheels(manifest["wheels"])
    assert not isinstance(versions, str), versions
    item = {"blender_version_min": manifest["blender_version_min"], "platforms": manifest["platforms"],
            "python_versions": [".".join(str(i) for i in v) for v in versions]}
    if manifest.get("blender_version_max"):
        item["blender_version_max"] = manifest["blender_version_max"]
    said = []
    skipped = blender_ext.repository_filter_skip(
        item=item, filter_blender_version=blender_ext.blender_version_parse_or_error(blender.split()[0]),
        filter_python_version=python, filter_platform="linux-x64", skip_message_fn=said.append,
        error_fn=lambda ex: said.append(f"error: {ex}"))
    return "\n".join(said) if skipped else None


def wheels_blender_unpacks(manifest: dict, python: tuple, blender_ext) -> list[str]:
    """The wheels Blender unpacks on linux-x64 for this Python: bl_extension_ops'
    `_extensions_wheel_filter_for_this_system`, run from its own source with this Python and platform."""
    path = os.path.join(_bl_pkg_folder(), "bl_extension_ops.py")
    with open(path) as f:
        source = f.read()
    [node] = [n for n in ast.parse(source).body
              if isinstance(n, ast.FunctionDef) and n.name == "_extensions_wheel_filter_for_this_system"]
    modules = {"sys": SimpleNamespace(version_info=python),
               "sysconfig": SimpleNamespace(get_platform=lambda: "linux-x86_64"), "bl_extension_utils": blender_ext}

    def importer(name, globals=None, locals=None, fromlist=(), level=0):
        return modules[name] if name in modules else builtins.__import__(name, globals, locals, fromlist, level)

    scope = {"__builtins__": {**vars(builtins), "__import__": importer},
             "bpy": SimpleNamespace(app=SimpleNamespace(debug_python=False))}
    exec(compile(ast.Module([node], []), path, "exec"), scope)
    return scope["_extensions_wheel_filter_for_this_system"](manifest["wheels"])


def test_every_zip_claims_blender_from_4_2_and_leaves_its_python_to_its_wheels():
    with open(os.path.join(bundle.ROOT, "blender_manifest.toml")) as f:
        repository = tomllib.loads(f.read())
    assert repository["blender_version_min"] == "4.2.0"  # the first Blender with extensions and their wheels
    for tag in bundle.PYTHON_LINES:
        manifest = _zip_manifest(tag)
        assert (manifest["blender_version_min"], manifest.get("blender_version_max")) == \
            (repository["blender_version_min"], repository.get("blender_version_max")), tag
        assert "python_versions" not in manifest  # not a manifest key: Blender reads it off the wheels


@pytest.mark.parametrize("blender", list(BLENDERS))
def test_each_blender_accepts_exactly_the_zip_of_its_python(blender_ext, blender):
    python = BLENDERS[blender]
    own = "py%d%d" % python[:2]
    for tag in bundle.PYTHON_LINES:
        manifest = _zip_manifest(tag)
        refusal = blender_refusal(blender_ext, manifest, blender, python)
        if tag == own:
            assert refusal is None, (blender, tag, refusal)
            assert wheels_blender_unpacks(manifest, python[:2], blender_ext) == manifest["wheels"], (blender, tag)
        else:
            other = bundle.PYTHON_LINES[tag].version
            assert refusal == f"This Python version (%d.%d) isn't compatible with ({other})" % python[:2], \
                (blender, tag)


def test_the_old_ranges_refused_debians_blender_and_the_zips_now_do_not(blender_ext):
    # the report: Debian's 4.3.2 on Python 3.13 against the py313 zip of Blender 5.1 to <5.4
    old = {**_zip_manifest("py313"), "blender_version_min": "5.1.0"}
    assert blender_refusal(blender_ext, old, "4.3.2", (3, 13, 5)) == \
        "This Blender version (4.3.2) doesn't meet the minimum supported version (5.1.0)"
    assert blender_refusal(blender_ext, _zip_manifest("py313"), "4.3.2", (3, 13, 5)) is None


def test_a_blender_on_a_python_without_a_zip_is_refused_and_the_preferences_say_so(blender_ext):
    for tag in bundle.PYTHON_LINES:  # e.g. a distribution's Blender built with Python 3.12
        assert "This Python version (3.12) isn't compatible" in blender_refusal(
            blender_ext, _zip_manifest(tag), "4.5.0", (3, 12, 3))
    assert "no zip is built for Python 3.12" in bundle_status.right_zip((3, 12))
    assert bundle_status.right_zip((3, 13)).startswith("install the zip for Python 3.13 (")
    assert tuple(line.version for line in bundle.PYTHON_LINES.values()) == bundle_status.ZIP_PYTHONS


def test_each_zip_says_which_numpy_its_opencv_needs():
    py311, py313 = bundle.PYTHON_LINES["py311"], bundle.PYTHON_LINES["py313"]
    assert py311.numpy == "numpy>=1.26" and py311.opencv.startswith("4.11.")  # the last for numpy 1
    assert py313.numpy == "numpy>=2" and py313.opencv.startswith("4.12.")  # the first for numpy 2
    info = bundle.bundle_info(bundle.plan("linux-x64", "py313", lock=[]), [], ("4.2.0", "5.4.0"))
    assert info["numpy"] == "numpy>=2" and info["blender"] == ["4.2.0", "5.4.0"]
    assert "distributions" in info["blenders"]
    # the numpy each Blender of that Python brings: official 4.2 to 5.0 1.26.4, 5.1 to 5.3 2.2.6 (the version
    # matrix), Debian trixie's 4.3.2 the system's 2.2.4
    assert bundle_status.numpy_fits(py311.numpy, "1.26.4") and not bundle_status.numpy_fits(py311.numpy, "1.24.4")
    for numpy in ("2.2.4", "2.2.6", "2.3.5"):
        assert bundle_status.numpy_fits(py313.numpy, numpy), numpy
    assert not bundle_status.numpy_fits(py313.numpy, "1.26.4") and bundle_status.numpy_fits("numpy>=2,<2.3", "2.2.9")
    assert not bundle_status.numpy_fits("numpy>=2,<2.3", "2.3.0")
