"""One name for the extension's code in a test run: the top-level names refused, and the source files a run
loaded under more than one module name found."""
import importlib.abc
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGES = ("lapig_core", "lapig_addon", "operators", "panels", "tools")  # the extension's code and its tools


def files_loaded_twice(modules=None) -> dict:
    """Source files loaded as more than one module: {file: [module names]}."""
    names: dict = {}
    for name, module in list((modules if modules is not None else sys.modules).items()):
        path = getattr(module, "__file__", None)
        if path and pathlib.Path(path).resolve().is_relative_to(ROOT) and \
                pathlib.Path(path).resolve().relative_to(ROOT).parts[0] in PACKAGES:
            names.setdefault(str(pathlib.Path(path).resolve()), []).append(name)
    return {path: sorted(found) for path, found in names.items() if len(found) > 1}


class TopLevelNamesRefused(importlib.abc.MetaPathFinder):
    """`import lapig_core` (or lapig_addon, operators, panels, tools) fails as it does in the installed
    extension, where only `bl_ext.<repo>.lapig.lapig_core` exists; the tests use `lapig.lapig_core`."""

    def find_spec(self, fullname, path=None, target=None):
        top = fullname.partition(".")[0]
        if top in PACKAGES:
            raise ModuleNotFoundError(f"No module named '{fullname}': the extension's code is "
                                      f"'lapig.{fullname}' in the tests (and has no top-level name installed)",
                                      name=fullname)
        return None
