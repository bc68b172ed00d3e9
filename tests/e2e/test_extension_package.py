import importlib.util
import os
import subprocess
import sys

import pytest

pytest.importorskip("bpy")


@pytest.mark.e2e
def test_extension_builds_installs_enables_runs_and_disables(tmp_path):
    """With torch: capture, train, generate, preview, export. Without (the version matrix): capture,
    preview and export of an existing result."""
    from lapig.tools.packaging import build_extension

    zip_path = build_extension(str(tmp_path / "dist"))
    user = tmp_path / "blender_user"
    user.mkdir()
    work = tmp_path / "work"
    work.mkdir()
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user))
    script = os.path.join(os.path.dirname(__file__), "install_and_run.py")
    torch_free = [] if importlib.util.find_spec("torch") else ["--torch-free"]
    proc = subprocess.run([sys.executable, script, zip_path, str(work)] + torch_free, env=env, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0 and "E2E OK" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-3000:]
    if not torch_free:  # the installed package's every module, and the real rig through its operators
        assert "E2E MODULES imported" in proc.stdout and "E2E REAL RIG simulated" in proc.stdout, proc.stdout[-3000:]


def test_zip_holds_only_tracked_files_of_the_extension(tmp_path):
    """Stray files in the checkout, tests, tools and benchmark-only weights stay out of the zip (the stray file
    goes into a clone of the checkout: a test never writes into the source tree)."""
    import zipfile

    from lapig.tools.packaging import ROOT, build_extension, tracked_files

    checkout = tmp_path / "checkout"
    subprocess.run(["git", "clone", "-q", "--local", ROOT, str(checkout)], check=True, capture_output=True)
    (checkout / "lapig_core" / "stray_untracked_test_file.py").write_text("# not tracked by git\n")
    assert "lapig_core/stray_untracked_test_file.py" not in tracked_files(str(checkout))
    names = zipfile.ZipFile(build_extension(str(tmp_path / "dist"), str(checkout))).namelist()
    assert "blender_manifest.toml" in names and "lapig_core/photometric/weights/pcnet_pretrained.pt" in names
    left_out = ("tests/", "tools/", "benchmarks/", "scripts/", "docs/architecture/")
    assert not [n for n in names if n.startswith(left_out)]
    assert "docs/installing.md" in names  # the page the preferences and the dependency message point at
    assert not [n for n in names if "stray_untracked" in n or n.endswith((".blend", "_reversed_pretrained.pt"))]
