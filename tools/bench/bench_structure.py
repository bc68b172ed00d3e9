"""bench structure: issue 51's figures of the house, counted from the tree (git), nothing run.

- product_lines: the lines of the product's .py files (lapig_core, lapig_addon, operators, panels) git tracks,
  as they are in the working tree; product_lines_base the same at BASE (97dd9cd, issue 51's count before; None
  where the clone has no such commit, e.g. a shallow one) and product_lines_change the difference. The features
  other issues added since BASE are not told apart here: the closing notes count them by path.
- services_named_multi_or_several, joint_refine_twin: what the issue says must be gone.
- projector_count_branches: the places in the product that compare a projector count with 1 (at most 3 allowed).
- readme_lines, docs_pages, benchmarks_table_first_line: the documents' checks (README at most 200 lines,
  at least 6 pages in docs/, the current-figures table within BENCHMARKS.md's first 80 lines).
"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BASE = "97dd9cd"
PRODUCT = ("lapig_core", "lapig_addon", "operators", "panels")
COUNT_BRANCH = re.compile(r"projector_count\s*(>|>=|==|!=|<)\s*[12]\b|len\([\w.]*projectors\)\s*(>|==|<)\s*1\b")


def _git(*args) -> str:
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, check=True).stdout


def _product_files(rev: str | None = None) -> list[str]:
    listing = _git("ls-tree", "-r", "--name-only", rev, "--", *PRODUCT) if rev else _git("ls-files", "--", *PRODUCT)
    return [f for f in listing.splitlines() if f.endswith(".py")]


def product_lines(rev: str | None = None) -> int:
    """Lines of the product's Python files: the working tree's (rev None) or those of commit `rev`."""
    if rev is None:
        return sum(len((ROOT / f).read_text(encoding="utf-8").splitlines()) for f in _product_files())
    return sum(len(_git("show", f"{rev}:{f}").splitlines()) for f in _product_files(rev))


def _base_lines():
    try:
        _git("cat-file", "-e", f"{BASE}^{{commit}}")
    except subprocess.CalledProcessError:
        return None
    return product_lines(BASE)


def run(args) -> dict:
    lines, base = product_lines(), _base_lines()
    branches = [f"{f}:{n}" for f in _product_files()
                for n, text in enumerate((ROOT / f).read_text(encoding="utf-8").splitlines(), 1)
                if COUNT_BRANCH.search(text) and not text.lstrip().startswith("#")]
    services = ROOT / "lapig_addon" / "services"
    table = next((n for n, text in enumerate((ROOT / "BENCHMARKS.md").read_text(encoding="utf-8").splitlines(), 1)
                  if text.startswith("| benchmark |")), None)
    return {"benchmark": "structure", "base": BASE, "product_lines": lines, "product_lines_base": base,
            "product_lines_change": None if base is None else lines - base,
            "services_named_multi_or_several": sorted(p.name for p in services.rglob("*.py")
                                                      if p.name.startswith(("multi_", "several_"))),
            "joint_refine_twin": (ROOT / "lapig_core" / "multi" / "refine.py").exists(),
            "projector_count_branches": branches,
            "readme_lines": len((ROOT / "README.md").read_text(encoding="utf-8").splitlines()),
            "docs_pages": len(list((ROOT / "docs").glob("*.md"))),
            "benchmarks_table_first_line": table}
