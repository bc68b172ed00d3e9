"""The manual and the developers' documents hold together: every relative link and #anchor resolves (as GitHub
makes anchors), the README is a front page, BENCHMARKS.md opens with the current figures of every benchmark, the
CLI page names every benchmark, and the layout page names every product package and module. bpy-free, no torch.
"""
from __future__ import annotations

import ast
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
PRODUCT = ("lapig_core", "lapig_addon", "operators", "panels")
FENCE = re.compile(r"^\s*(```|~~~)")
LINK = re.compile(r"!?\[(?:[^\]\\]|\\.)*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")


def documents() -> list[pathlib.Path]:
    """The documents whose links must resolve: the front page, the architecture and every page of docs/."""
    return [ROOT / "README.md", ROOT / "ARCHITECTURE.md"] + sorted(DOCS.rglob("*.md"))


def prose_lines(text: str):
    """(line number, line) outside fenced code blocks, inline code spans removed."""
    fenced = False
    for number, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            yield number, re.sub(r"`[^`]*`", "", line)


def github_slug(heading: str) -> str:
    """GitHub's anchor of a heading: its text (code spans and emphasis kept as text), lower case, punctuation
    other than '-' and '_' dropped, each space a '-'."""
    text = re.sub(r"`([^`]*)`", r"\1", heading.strip())
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link in a heading: its text
    text = re.sub(r"[*~]", "", text).lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: pathlib.Path) -> set[str]:
    """Every heading's anchor in a Markdown file, duplicates numbered as GitHub numbers them (-1, -2, ...)."""
    seen: dict[str, int] = {}
    found = set()
    fenced = False
    for line in path.read_text(encoding="utf-8").splitlines():
        if FENCE.match(line):
            fenced = not fenced
            continue
        match = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if fenced or not match:
            continue
        slug = github_slug(match.group(1))
        count = seen.get(slug, 0)
        seen[slug] = count + 1
        found.add(slug if count == 0 else f"{slug}-{count}")
    return found


def link_problems(path: pathlib.Path, only_lines: int | None = None) -> list[str]:
    """A line for each relative link of `path` whose file or #anchor does not exist."""
    problems = []
    text = path.read_text(encoding="utf-8")
    for number, line in prose_lines(text):
        if only_lines is not None and number > only_lines:
            break
        for target in LINK.findall(line):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # https:, mailto: ...
                continue
            file_part, _, anchor = target.partition("#")
            linked = (path.parent / file_part).resolve() if file_part else path
            where = f"{path.relative_to(ROOT)}:{number}: {target}"
            if not linked.exists():
                problems.append(f"{where}: no such file")
            elif anchor and linked.suffix == ".md" and anchor not in anchors(linked):
                problems.append(f"{where}: no heading #{anchor} in {linked.relative_to(ROOT)}")
            elif anchor and linked.suffix != ".md":
                problems.append(f"{where}: an anchor into a file that is not Markdown")
    return problems


def benchmark_names() -> list[str]:
    """The `bench` names of tools/dev_commands.py's BENCHMARKS, read from its source (it imports bpy)."""
    tree = ast.parse((ROOT / "tools" / "dev_commands.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "BENCHMARKS" for t in node.targets):
            return list(ast.literal_eval(node.value))
    raise AssertionError("tools/dev_commands.py has no BENCHMARKS table")


def product_packages() -> list[str]:
    """Every folder of the product that holds Python modules or its data (weights), as 'lapig_core/psa'."""
    folders = set()
    for top in PRODUCT:
        for path in (ROOT / top).rglob("*"):
            if path.is_file() and "__pycache__" not in path.parts:
                folders.add(path.parent.relative_to(ROOT).as_posix())
    return sorted(folders)


def test_github_slug_matches_githubs_rules():
    assert github_slug("Installing the Python dependencies into Blender") == \
        "installing-the-python-dependencies-into-blender"
    assert github_slug("torch and the GPU") == "torch-and-the-gpu"
    assert github_slug("Panel lines cut at the sidebar's width (issue 49: `bench ui --parts panel`, `cut_lines`)") == \
        "panel-lines-cut-at-the-sidebars-width-issue-49-bench-ui---parts-panel-cut_lines"
    assert github_slug("lapig_core/export/: the MPCDI package") == "lapig_coreexport-the-mpcdi-package"


def test_link_check_finds_a_broken_link_and_a_broken_anchor(tmp_path, monkeypatch):
    monkeypatch.setitem(globals(), "ROOT", tmp_path)
    page = tmp_path / "page.md"
    (tmp_path / "other.md").write_text("# Other\n## A part\n## A part\n")
    page.write_text("# Page\n[ok](other.md#a-part-1) [self](#page) [gone](missing.md) [bad](other.md#nowhere)\n"
                    "```\n[in code](ignored.md)\n```\n`[inline](ignored.md)` [web](https://example.com)\n")
    problems = link_problems(page)
    assert len(problems) == 2, problems
    assert "missing.md: no such file" in problems[0] and "no heading #nowhere" in problems[1]


@pytest.mark.parametrize("path", documents(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_relative_link_and_anchor_resolves(path):
    assert not link_problems(path)


def test_the_current_figures_table_links_resolve():
    assert not link_problems(ROOT / "BENCHMARKS.md", only_lines=80)


def test_readme_is_a_front_page_that_opens_with_the_two_commands():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 200, f"README.md has {len(lines)} lines: move the detail into docs/"
    assert lines[0].startswith("# ")
    block = [line for line in lines[1:8] if line.strip()]
    assert block[0] == "```bash", block
    assert block[1].startswith("bash run_demo.sh") and block[2].startswith("bash run_tests.sh") and block[3] == "```"


def test_docs_has_the_manuals_pages():
    pages = sorted(p.name for p in DOCS.glob("*.md"))
    assert len(pages) >= 6, pages
    for page in ("using-the-panel.md", "real-rigs.md", "several-projectors.md", "shows-and-video.md",
                 "light-and-units.md", "cli.md", "troubleshooting.md", "installing.md", "development.md"):
        assert page in pages
        assert f"docs/{page}" in (ROOT / "README.md").read_text(encoding="utf-8"), f"README does not link {page}"


def test_every_benchmark_has_a_current_figure_row_and_a_cli_entry():
    head = "\n".join((ROOT / "BENCHMARKS.md").read_text(encoding="utf-8").splitlines()[:80])
    cli = (DOCS / "cli.md").read_text(encoding="utf-8")
    names = benchmark_names() + ["demo"]
    assert len(names) > 20
    no_row = [n for n in names if not re.search(rf"^\| `{re.escape(n)}` \|", head, re.MULTILINE)]
    assert not no_row, f"BENCHMARKS.md's first 80 lines have no row for {no_row}"
    assert not [n for n in benchmark_names() if not re.search(rf"^\| `{re.escape(n)}` \|", cli, re.MULTILINE)]
    assert "\n# History\n" in (ROOT / "BENCHMARKS.md").read_text(encoding="utf-8")


def test_the_layout_page_names_every_product_package_and_module():
    layout = (DOCS / "architecture" / "layout.md").read_text(encoding="utf-8")
    folders = product_packages()
    assert "lapig_core/photometric/archs" in folders and "panels" in folders
    assert not [f for f in folders if f"{f}/" not in layout], "docs/architecture/layout.md lacks a folder"
    modules = sorted({p.stem for top in PRODUCT for p in (ROOT / top).rglob("*.py")
                      if "__pycache__" not in p.parts and not p.stem.startswith("__")})
    missing = [m for m in modules if not re.search(rf"`{re.escape(m)}[`.( ]", layout)]
    assert not missing, f"docs/architecture/layout.md does not name {missing}"


def test_the_install_page_the_code_points_at_exists():
    from lapig.lapig_core.common.deps import INSTALL_DOC, needs_message

    page, _, anchor = INSTALL_DOC.partition("#")
    assert (ROOT / page).is_file() and anchor in anchors(ROOT / page)
    assert INSTALL_DOC in needs_message(["torch"])
    product = [p for top in PRODUCT for p in (ROOT / top).rglob("*.py") if "__pycache__" not in p.parts]
    assert not [p for p in product if re.search(r"README[^\n]*'[A-Z][a-z]+ ", p.read_text(encoding="utf-8"))], \
        "a module names a README section: point at a docs/ page instead"
