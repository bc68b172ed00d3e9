"""The guard that fails a run writing into the checkout: it sees additions, changes and removals."""
from source_tree_guard import changes, snapshot


def test_added_changed_and_removed_files_are_named(tmp_path):
    (tmp_path / "kept.py").write_text("a = 1\n")
    (tmp_path / "edited.py").write_text("b = 1\n")
    (tmp_path / "gone.txt").write_text("x")
    before = snapshot(tmp_path)
    (tmp_path / "edited.py").write_text("b = 22\n")
    (tmp_path / "gone.txt").unlink()
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "result.json").write_text("{}")
    assert changes(before, snapshot(tmp_path)) == ["changed edited.py", "removed gone.txt", "added out/result.json"]


def test_tool_folders_are_left_out(tmp_path):
    before = snapshot(tmp_path)
    for folder in (".git", ".venv", "__pycache__", ".pytest_cache", "lapig_core/__pycache__"):
        (tmp_path / folder).mkdir(parents=True)
        (tmp_path / folder / "file").write_text("x")
    assert changes(before, snapshot(tmp_path)) == []
