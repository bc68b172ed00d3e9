"""The Linux zip that carries its wheels, installed into a private user folder of a Python that has only
bpy and what the bpy wheel itself needs (numpy, requests, zstandard, cython: what Blender ships), then the
artist's whole path: Capture, Train, Generate, preview, export, disable.

Building the zip downloads its wheels once into the user's cache (tools/bundle.py, wheel_cache_root; torch's
CPU build comes from this machine's disk where pip finds it there); LAPIG_SKIP_BUNDLE=1 skips the test on a machine without the package index.
"""
import importlib.util
import json
import os
import subprocess
import sys

import pytest

pytest.importorskip("bpy")
pytestmark = [pytest.mark.e2e, pytest.mark.torch]  # builds from the torch of this venv's lock


def bare_blender_python(folder) -> str:
    """A venv of this interpreter whose only packages are bpy and its own requirements, linked from this
    venv (no download): what a Blender installation offers an extension."""
    import venv

    venv.EnvBuilder(with_pip=False).create(str(folder / "venv"))
    only = folder / "site"
    only.mkdir()
    from lapig.tools.bundle import installed_closure

    for dist in installed_closure(["bpy"]).values():
        for top in {str(f).split("/")[0] for f in dist.files or []}:
            source = dist.locate_file(top)
            if top not in ("..", "bin") and os.path.exists(source) and not os.path.exists(only / top):
                os.symlink(source, only / top)
    [site] = (folder / "venv" / "lib").glob("python*/site-packages")
    (site / "blender_only.pth").write_text(str(only) + "\n")
    python = str(folder / "venv" / "bin" / "python")
    found = subprocess.run([python, "-c", "import importlib.util as u; print([m for m in ('torch', 'cv2', "
                            "'scipy', 'sentence_transformers', 'bpy') if u.find_spec(m)])"],
                           capture_output=True, text=True, check=True).stdout.strip()
    assert found == "['bpy']", found
    return python


@pytest.mark.skipif(os.environ.get("LAPIG_SKIP_BUNDLE") == "1", reason="LAPIG_SKIP_BUNDLE=1")
@pytest.mark.skipif(not sys.platform.startswith("linux") or sys.version_info[:2] != (3, 11),
                    reason="the Linux zip for Python 3.11 (official Blender 4.2 to 5.0) is the one tested here")
def test_the_linux_zip_alone_gives_a_working_generate(tmp_path):
    from lapig.tools.bundle import build_platform_zip

    built = build_platform_zip("linux-x64", "py311", str(tmp_path / "dist"))
    assert built["not_bundled"] == [] and built["wheels"] > 20
    user, work = tmp_path / "blender_user", tmp_path / "work"
    user.mkdir()
    work.mkdir()
    python = bare_blender_python(tmp_path / "bare")
    script = os.path.join(os.path.dirname(__file__), "install_and_run.py")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
    env.update(BLENDER_USER_RESOURCES=str(user), HF_HUB_OFFLINE="1")
    proc = subprocess.run([python, script, built["path"], str(work), "--bundled"], env=env, capture_output=True,
                          text=True, timeout=1800)
    assert proc.returncode == 0 and "E2E OK" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "E2E MODULES imported" in proc.stdout and "E2E REAL RIG simulated" in proc.stdout, proc.stdout[-3000:]
    timing = json.loads(proc.stdout.split("E2E TIMING ")[1].splitlines()[0])
    print(f"zip {built['mb']} MB; install to finished Generate {timing['install_to_generate_seconds']} s")
    assert importlib.util.find_spec("torch")  # the zip was built from this venv's torch
