"""Issue 53, end to end in the installed extension: a local hub (HF_ENDPOINT) serves a tiny InstructPix2Pix and a
tiny depth adapter made by the test; the installed add-on's Download fetches both, and Generate draws through them
along the rig's depth (install_and_stylize.py, in a fresh Python without the repository on sys.path)."""
import os
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("bpy")
pytest.importorskip("torch")
pytest.importorskip("diffusers")
pytest.importorskip("transformers")

IP2P_REPO, DEPTH_REPO = "timbrooks/instruct-pix2pix", "TencentARC/t2iadapter_depth_sd15v2"  # the catalogue's


@pytest.mark.e2e
@pytest.mark.torch
def test_installed_manager_downloads_the_models_and_generate_follows_the_depth(tmp_path):
    from PIL import Image

    from lapig.tools.bench.fake_model_hub import FakeModelHub
    from lapig.tools.bench.tiny_pipeline import make_tiny_adapter, make_tiny_pipeline
    from lapig.tools.packaging import build_extension

    repos = {IP2P_REPO: make_tiny_pipeline(tmp_path / "repo_ip2p", "ip2p"),
             DEPTH_REPO: make_tiny_adapter(tmp_path / "repo_depth")}
    zip_path = build_extension(str(tmp_path / "dist"))
    user, work = tmp_path / "blender_user", tmp_path / "work"
    user.mkdir()
    work.mkdir()
    script = os.path.join(os.path.dirname(__file__), "install_and_stylize.py")
    with FakeModelHub(repos) as hub, FakeModelHub(repos) as offline_hub:
        env = dict(os.environ, BLENDER_USER_RESOURCES=str(user), HF_ENDPOINT=hub.url)
        proc = subprocess.run([sys.executable, script, zip_path, str(work), offline_hub.url], env=env,
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0 and "E2E OK" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-3000:]
        assert offline_hub.requests == []  # online access off: nothing was asked of the network
        fetched = {path for path, _, _ in hub.requests if path.startswith("/cdn/")}
        for weights in (f"/cdn/{IP2P_REPO}/unet/diffusion_pytorch_model.safetensors",
                        f"/cdn/{DEPTH_REPO}/diffusion_pytorch_model.bin"):  # from HF_ENDPOINT's hub
            assert weights in fetched, sorted(fetched)
    refused = [line for line in proc.stdout.splitlines() if line.startswith("E2E OFFLINE refused: ")]
    assert len(refused) == 1 and "Allow Online Access" in refused[0], proc.stdout[-3000:]
    result = [line.split(" ", 2)[2] for line in proc.stdout.splitlines() if line.startswith("E2E RESULT ")][0]
    projector = np.asarray(Image.open(os.path.join(result, "projector.png")).convert("RGB"), dtype=np.float32)
    assert projector.max() > 0 and projector.std() > 1.0, "the projector image is blank"
    assert "E2E STEPPED depth-adapter" in proc.stdout  # the UI's path: Download returned, the timer's steps ran it
    print("\n".join(line for line in proc.stdout.splitlines() if line.startswith(("E2E DOWN", "E2E STEP", "E2E TIM"))))
