"""What the preferences say about the zip's bundled wheels (bpy-free)."""
import importlib
import json


def _status():
    return importlib.import_module("lapig.lapig_addon.services.panel.bundle_status")


def test_a_checkout_without_bundle_json_says_the_packages_come_from_blenders_python(tmp_path):
    status = _status()
    assert status.read_bundle(str(tmp_path / "bundle.json")) is None
    (tmp_path / "bundle.json").write_text("{not json")
    assert status.read_bundle(str(tmp_path / "bundle.json")) is None
    [line] = status.bundle_lines(None)
    assert "No bundled wheels" in line.text


def test_a_zip_that_lacks_torch_names_the_reason_and_the_next_step(tmp_path):
    status = _status()
    info = {"platform": "linux-x64", "python": "3.13", "bundled": [{"name": "onnx", "version": "1.23.2"}],
            "not_bundled": [{"package": "torch", "reason": "no CPU build", "next_step": "press Copy"}]}
    (tmp_path / "bundle.json").write_text(json.dumps(info))
    lines = [line.text for line in status.bundle_lines(status.read_bundle(str(tmp_path / "bundle.json")), (3, 13))]
    assert lines == ["This zip carries 1 wheels for linux-x64, Python 3.13",
                     "torch is not in this zip: no CPU build", "Next: press Copy"]


def test_a_zip_for_another_python_says_which_zip_to_install():
    lines = _status().bundle_lines({"platform": "linux-x64", "python": "3.11", "bundled": []}, (3, 13))
    assert "install the zip for Python 3.13 (lapig-<version>-<platform>-py313.zip)" in lines[1].text
    assert lines[1].icon == "ERROR" and "Blender 5" not in lines[1].text  # by Python, not by Blender release


def test_a_python_313_blender_with_numpy_1_is_told_the_zips_opencv_will_not_load():
    info = {"platform": "linux-x64", "python": "3.13", "numpy": "numpy>=2", "bundled": []}
    lines = _status().bundle_lines(info, (3, 13), numpy_version="1.26.4")
    assert [line.icon for line in lines] == ["PACKAGE", "ERROR"]
    assert "numpy is 1.26.4, and this zip's OpenCV needs numpy>=2" in lines[1].text
    assert len(_status().bundle_lines(info, (3, 13), numpy_version="2.2.4")) == 1  # Debian trixie's numpy fits
