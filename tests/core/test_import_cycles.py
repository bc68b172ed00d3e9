"""No import cycles in the package, counting function-level imports too (they only hide a cycle)."""
import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[2]
PACKAGES = ("lapig_core", "lapig_addon", "operators", "panels", "tools")


def _modules() -> dict:
    mods = {}
    for top in PACKAGES:
        for path in (ROOT / top).rglob("*.py"):
            parts = path.relative_to(ROOT).with_suffix("").parts
            mods[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return mods


def _graph(mods: dict) -> dict:
    graph = {}
    for name, path in mods.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        deps = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.ImportFrom) and node.level):
                continue
            base = package.split(".")[: len(package.split(".")) - (node.level - 1)] if package else []
            module = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                deps.add(f"{module}.{alias.name}" if f"{module}.{alias.name}" in mods else module)
        graph[name] = {d for d in deps if d in mods and d != name}
    return graph


def _cycle_from(start, graph):
    """A path start -> ... -> start, or None (depth-first)."""
    stack, seen = [(start, [start])], set()
    while stack:
        node, path = stack.pop()
        for nxt in graph[node]:
            if nxt == start:
                return path + [start]
            if nxt not in seen:
                seen.add(nxt)
                stack.append((nxt, path + [nxt]))
    return None


def test_no_import_cycles():
    mods = _modules()
    assert "lapig_core.capture.sequence" in mods and "lapig_addon.blender.scene_state" in mods
    graph = _graph(mods)
    cycles = [c for c in (_cycle_from(m, graph) for m in sorted(graph)) if c]
    assert not cycles, "\n".join(" -> ".join(c) for c in cycles[:5])
