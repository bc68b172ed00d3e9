# SPDX-License-Identifier: GPL-3.0-or-later
"""Every test file's name is unique across tests/: the tiers have no __init__.py, so pytest imports each file
by its base name, and two files of one name stop the whole run at collection ("import file mismatch")."""
from collections import defaultdict
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]


def test_no_two_test_files_share_a_name():
    by_name = defaultdict(list)
    for path in TESTS.rglob("test_*.py"):
        if "data" not in path.relative_to(TESTS).parts:
            by_name[path.name].append(str(path.relative_to(TESTS)))
    shared = {name: paths for name, paths in by_name.items() if len(paths) > 1}
    assert not shared, f"rename one of each: {shared}"
