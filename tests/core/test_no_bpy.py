"""lapig_core is plain Python: every module imports with bpy blocked (an import of bpy raises)."""
import pathlib
import subprocess
import sys

CORE = pathlib.Path(__file__).resolve().parents[2] / "lapig_core"


def core_modules():
    names = []
    for path in sorted(CORE.rglob("*.py")):
        parts = path.relative_to(CORE.parent).with_suffix("").parts
        names.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return names


def test_every_core_module_imports_without_bpy():
    modules = core_modules()
    assert len(modules) > 40  # the walk found the package, not an empty folder
    code = ("import importlib, importlib.util, sys\n"
            "sys.modules['bpy'] = None  # 'import bpy' now raises ImportError\n"
            f"failed = []\n"
            f"for name in {modules!r}:\n"
            "    try:\n"
            "        importlib.import_module(name)\n"
            "    except ImportError as exc:\n"
            "        if (exc.name or '').split('.')[0] == 'torch' and importlib.util.find_spec('torch') is None:\n"
            "            continue  # a torch-free venv of the version matrix: only bpy matters here\n"
            "        failed.append(f'{name}: {exc}')\n"
            "print('\\n'.join(failed))\n"
            "sys.exit(1 if failed else 0)\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=CORE.parent)
    assert run.returncode == 0, run.stdout + run.stderr
