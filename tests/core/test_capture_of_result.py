# SPDX-License-Identifier: GPL-3.0-or-later
"""A result's capture found again after the project moved (lapig_core/export/result_files.capture_of_result):
result.json records an absolute path, and a .blend copied with its data folder must still export and refine."""
from lapig.lapig_core.export.result_files import capture_of_result


def _project(root):
    capture = root / "wall_lapig" / "Wall" / "setups" / "Wall"
    result = root / "wall_lapig" / "results" / "20261207_look"
    capture.mkdir(parents=True)
    result.mkdir(parents=True)
    return capture, result


def test_the_recorded_capture_is_kept_where_it_still_is(tmp_path):
    capture, result = _project(tmp_path)
    assert capture_of_result(result, {"capture": str(capture)}) == str(capture)


def test_a_moved_project_finds_its_capture_in_its_own_data_folder(tmp_path):
    capture, result = _project(tmp_path / "moved")
    recorded = "/somewhere/gone/wall_lapig/Wall/setups/Wall"
    assert capture_of_result(result, {"capture": recorded}) == str(capture)


def test_a_capture_found_nowhere_stays_as_recorded_and_none_stays_empty(tmp_path):
    _, result = _project(tmp_path)
    assert capture_of_result(result, {"capture": "/gone/x_lapig/Other/setups/Other"}) == \
        "/gone/x_lapig/Other/setups/Other"
    assert capture_of_result(result, {}) == ""
    # a short tail is never taken for the capture: "setups/Wall" alone could be any object's
    assert capture_of_result(result, {"capture": "/gone/setups/Wall"}) == "/gone/setups/Wall"


def test_a_copied_project_takes_its_own_capture_while_the_original_still_stands(tmp_path):
    original, _ = _project(tmp_path / "original")
    copy_capture, copy_result = _project(tmp_path / "copy")
    assert capture_of_result(copy_result, {"capture": str(original)}) == str(copy_capture)
