#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The device check without Blender: loads the repository root as the package `lapig` (as the add-on's code
is imported everywhere) and runs tools/bench/bench_device.main. See tools/device_check.sh."""
import importlib.util
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent


def _load_extension_package(name="lapig"):
    spec = importlib.util.spec_from_file_location(name, ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
    package = importlib.util.module_from_spec(spec)
    sys.modules[name] = package
    spec.loader.exec_module(package)
    return package


if __name__ == "__main__":
    sys.path[:] = [p for p in sys.path if pathlib.Path(p or ".").resolve() != ROOT]  # one name for each file
    _load_extension_package()
    from lapig.tools.bench.bench_device import main  # noqa: E402

    sys.exit(main(sys.argv[1:]))
