"""`python -m lapig_addon ...`: the headless command line through the bpy module.

The add-on uses relative imports only (an extension rule), so it must run as a sub-package of the
extension. Run from the repository root, this loads the root as the package `lapig` first.
"""
import importlib.util
import pathlib
import sys


def _load_extension_package(name="lapig"):
    if name in sys.modules:
        return sys.modules[name]
    root = pathlib.Path(__file__).resolve().parent.parent
    spec = importlib.util.spec_from_file_location(name, root / "__init__.py",
                                                  submodule_search_locations=[str(root)])
    package = importlib.util.module_from_spec(spec)
    sys.modules[name] = package
    spec.loader.exec_module(package)
    return package


if __name__ == "__main__":
    _load_extension_package()
    from lapig.lapig_addon.cli import main as cli  # noqa: E402  (needs the package loaded above)

    from lapig.lapig_addon.blender import compat  # noqa: E402

    with compat.unregistered_at_exit():
        status = cli.main(sys.argv[1:])
    sys.exit(status)
