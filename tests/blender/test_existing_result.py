"""An existing result folder previews and exports without torch (the version matrix's torch-free tier)."""
import json
import os

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")


def write_fake_result(folder, width=64, height=48):
    """A result folder as Generate writes it, from plain arrays (no networks), at the projector's 4:3."""
    from lapig.lapig_core.export.result_files import write_result

    yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
    yy, xx = yy / (height - 1), xx / (width - 1)
    ramp = np.stack([xx, yy, 1 - xx], -1)
    images = {"target": ramp, "projector": ramp * 0.8, "simulated": ramp * 0.7, "compensability": ramp[..., :1] * 0,
              "target_nopsa": ramp[:, ::-1], "projector_nopsa": ramp[:, ::-1] * 0.8}
    images["compensability"] = np.repeat(images["compensability"], 3, -1)
    summary = {"prompt": "a ramp", "backend": "styletransfer", "seed": 0, "lgst": {"styles": [["ramp", 1.0]]},
               "psa": True, "metrics": {}}
    return str(write_result(folder, images, summary))


@pytest.mark.blender
def test_existing_result_previews_and_exports(small_setup, tmp_path):
    import cv2

    from lapig.lapig_addon.blender import preview

    scene, projector, camera, target = small_setup
    s = scene.lapig
    s.result_dir = write_fake_result(tmp_path / "result")
    original = [slot.material.name for slot in target.material_slots]
    for mode in ("TARGET", "SIMULATED", "COMPENSABILITY", "PROJECTION"):
        assert bpy.ops.lapig.preview_mode(mode=mode) == {"FINISHED"}
        assert preview.is_previewing(target)
    assert bpy.ops.lapig.preview_mode(mode="ORIGINAL") == {"FINISHED"}
    assert [slot.material.name for slot in target.material_slots] == original
    for depth, dtype in (("8", np.uint8), ("16", np.uint16)):
        s.export_bit_depth = depth
        path = str(tmp_path / f"projector {depth}.png")
        assert bpy.ops.lapig.export_image(filepath=path) == {"FINISHED"}
        data = cv2.imdecode(np.fromfile(path, np.uint8), cv2.IMREAD_UNCHANGED)
        assert data.dtype == dtype and data.shape == (120, 160, 3)
        side = json.load(open(path[:-4] + ".json", encoding="utf-8"))
        assert side["prompt"] == "a ramp" and side["software_blender"] == bpy.app.version_string
    s.crossfade_frames = 3
    assert bpy.ops.lapig.export_crossfade(directory=str(tmp_path / "fade")) == {"FINISHED"}
    assert len([f for f in os.listdir(tmp_path / "fade") if f.endswith(".png")]) == 3
