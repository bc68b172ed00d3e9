import os
import subprocess
import sys

import pytest

pytest.importorskip("bpy")


@pytest.mark.e2e
def test_extension_builds_installs_enables_runs_and_disables(tmp_path):
    from lapig.tools.packaging import build_extension

    zip_path = build_extension(str(tmp_path / "dist"))
    user = tmp_path / "blender_user"
    user.mkdir()
    work = tmp_path / "work"
    work.mkdir()
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user))
    script = os.path.join(os.path.dirname(__file__), "install_and_run.py")
    proc = subprocess.run([sys.executable, script, zip_path, str(work)], env=env, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0 and "E2E OK" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-3000:]
