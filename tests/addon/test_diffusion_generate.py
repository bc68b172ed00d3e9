# SPDX-License-Identifier: GPL-3.0-or-later
"""Generate with InstructPix2Pix and the depth adapter through the job, bpy blocked (issue 53, item 3): where the
store casts the projector's rays (Blender's look_geometry; here a tiny ball before a wall) the look follows that
depth and result.json says so; where it cannot (a real rig without a 3D model) the look says it is not followed."""
import importlib
import json
import os

import pytest

ADDON = "lapig.lapig_addon"


@pytest.fixture
def captured(seams):
    pytest.importorskip("torch")
    pytest.importorskip("diffusers")
    pytest.importorskip("transformers")
    capture_job = importlib.import_module(f"{ADDON}.services.capture.capture_job")
    capture_job.CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    return seams


def _generate(seams, tmp_path, geometry_shape=None):
    from lapig.tools.bench.tiny_pipeline import make_tiny_adapter, make_tiny_pipeline, tiny_geometry

    ip2p, depth = make_tiny_pipeline(tmp_path / "ip2p", "ip2p"), make_tiny_adapter(tmp_path / "depth")
    if geometry_shape:  # as BlenderSceneStore.look_geometry casts the projector's rays
        seams.store.look_geometry = lambda w, h: tiny_geometry(h, w, geometry_shape)
    jobs = importlib.import_module(f"{ADDON}.services.generate.generate_job")
    request = seams.store.generate_request(backend="instruct-pix2pix", ip2p_model=ip2p, depth_model=depth, psa=False,
                                           prompt="Make it a stained glass artwork")
    out = jobs.GenerateJob(seams, request, 2).run_to_completion()
    with open(os.path.join(out["folder"], "result.json"), encoding="utf-8") as f:
        return json.load(f), depth


def test_generate_follows_the_depth_the_store_casts(captured, tmp_path):
    summary, depth = _generate(captured, tmp_path, "ball")
    assert summary["lgst"]["backend"] == "instruct-pix2pix"
    assert summary["lgst"]["depth"]["used"] and summary["lgst"]["depth"]["adapter"] == depth


def test_without_a_3d_model_generate_says_the_depth_is_not_followed(captured, tmp_path):
    from lapig.lapig_core.diffusion.depth_condition import NO_DEPTH

    summary, depth = _generate(captured, tmp_path)  # the fake store casts no rays: the captured surface stands in
    assert summary["lgst"]["depth"] == {"adapter": depth, "used": False}
    assert NO_DEPTH in summary["lgst"]["notes"]
