"""Test setup: load the repository root as the extension package `lapig`, as Blender does, and only so.

The tests import the code as `lapig.lapig_core...` and `lapig.lapig_addon...`: under one name, as the
installed extension has it (a top-level `lapig_core` does not exist there, and two names would make two
copies of every class: an exception of one copy is not caught as the other's). The repository root is not
on sys.path (pytest.ini), and a run that loads a source file under two names fails at its end.
"""
import importlib.util
import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent


def _load_extension_package(name="lapig"):
    """The repository root as the package `name` (lapig_addon/__main__.py does the same for the CLI)."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
    package = importlib.util.module_from_spec(spec)
    sys.modules[name] = package
    spec.loader.exec_module(package)
    return package


# `python -m pytest` puts the working directory (the root) on sys.path, and pytest itself may (a root folder
# whose name is no Python name): take it off, and refuse the top-level names whatever sys.path holds
sys.path[:] = [p for p in sys.path if pathlib.Path(p or ".").resolve() != ROOT]
_load_extension_package()

from package_names import TopLevelNamesRefused, files_loaded_twice  # noqa: E402 (tests/ is the conftest's folder)
import source_tree_guard  # noqa: E402

sys.meta_path.insert(0, TopLevelNamesRefused())


_tree_before = {}


def pytest_sessionstart(session):
    _tree_before.update(source_tree_guard.snapshot(ROOT))


def pytest_sessionfinish(session, exitstatus):
    written = source_tree_guard.changes(_tree_before, source_tree_guard.snapshot(ROOT))
    if written and not session.config.getoption("collectonly"):
        print("\nerror: the run wrote into the source tree (tests write into tmp_path):\n  " + "\n  ".join(written[:40]),
              file=sys.stderr)
        session.exitstatus = 1
    twice = files_loaded_twice()
    if twice:
        lines = [f"{path}: {', '.join(names)}" for path, names in sorted(twice.items())]
        print("\nerror: the run loaded these files under two package names (import them as lapig.lapig_core... "
              "or lapig.lapig_addon...):\n  " + "\n  ".join(lines), file=sys.stderr)
        session.exitstatus = 1

HAS_TORCH = importlib.util.find_spec("torch") is not None


def pytest_collection_modifyitems(config, items):
    """Tests marked `torch` skip where torch is absent (the version matrix's torch-free venvs).
    Modules that import torch themselves use pytest.importorskip("torch")."""
    if HAS_TORCH:
        return
    skip = pytest.mark.skip(reason="needs torch, which is not installed")
    for item in items:
        if "torch" in item.keywords:
            item.add_marker(skip)
