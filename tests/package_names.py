"""Which source files of the repository a test run loaded under more than one module name."""
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
