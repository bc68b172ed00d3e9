"""Each zip installed with Blender's own Install from Disk operator in this bpy (5.0.1 on Python 3.11 in
`.venv`, 5.3.0 on Python 3.13 in the version matrix): the zip for this Python installs, enables and has its
wheels unpacked; the zip for the other Python is refused with Blender's words. The zips are the real
manifest and files with one tiny wheel each (tests/e2e/wheel_probe.py), so nothing downloads.
Debian's Blender 4.3.2 on Python 3.13 has no bpy wheel; tests/core/test_zip_compatibility.py checks it with
Blender's compatibility code.
"""
import json
import os
import subprocess
import sys

import pytest

from wheel_probe import write_probe_wheel

pytest.importorskip("bpy")
pytestmark = [pytest.mark.e2e]


def _zip_with_a_probe_wheel(python_tag: str, tmp_path) -> str:
    from lapig.tools import bundle

    wheels = tmp_path / f"wheels_{python_tag}"
    wheels.mkdir()
    cp = "cp" + python_tag[2:]
    probe = write_probe_wheel(str(wheels), cp, cp, "manylinux_2_28_x86_64")
    return bundle.assemble_zip(bundle.plan("linux-x64", python_tag, lock=[]), [probe], str(tmp_path / "dist"))["path"]


def _install(zip_path: str, user) -> dict:
    user.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
    env["BLENDER_USER_RESOURCES"] = str(user)
    script = os.path.join(os.path.dirname(__file__), "install_for_python.py")
    proc = subprocess.run([sys.executable, script, zip_path], env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and "ZIP RESULT " in proc.stdout, proc.stdout[-3000:] + proc.stderr[-3000:]
    return json.loads(proc.stdout.split("ZIP RESULT ")[1].splitlines()[0])


@pytest.mark.skipif(not sys.platform.startswith("linux") or sys.version_info[:2] not in ((3, 11), (3, 13)),
                    reason="the Linux zips are for Python 3.11 and 3.13")
def test_this_blender_installs_the_zip_of_its_python_and_refuses_the_other(tmp_path):
    here = "py%d%d" % sys.version_info[:2]
    other = {"py311": "py313", "py313": "py311"}[here]
    own = _install(_zip_with_a_probe_wheel(here, tmp_path), tmp_path / "user_own")
    assert own["enabled"] and own["wheel_unpacked"], own
    refused = _install(_zip_with_a_probe_wheel(other, tmp_path), tmp_path / "user_other")
    print(json.dumps({"own": own, "other": refused}, indent=1))
    # Blender copies the files, then its compatibility check (the wheels' Python) keeps it from enabling
    assert not refused["enabled"] and not refused["wheel_unpacked"], refused
    theirs = "3.13" if other == "py313" else "3.11"
    assert f"This Python version (%d.%d) isn't compatible with ({theirs})" % sys.version_info[:2] in \
        refused["said"] + " ".join(refused["result"]), refused


def test_blenders_cli_installs_both_zips_for_every_release_from_4_2(tmp_path):
    """`blender --command extension install-file` runs blender_ext.py's install-files, which checks the
    Blender range and the platform (the Python is checked on enabling, above and in the core test)."""
    from lapig.tools.packaging import blender_ext_cli

    for tag in ("py311", "py313"):
        path = _zip_with_a_probe_wheel(tag, tmp_path)
        for blender, python in (("4.2.0", "3.11.7"), ("4.3.2", "3.13.5"), ("5.0.1", "3.11.13"), ("5.3.0", "3.13.9"),
                                ("4.1.1", "3.11.7")):
            local = tmp_path / f"repo_{tag}_{blender}"
            local.mkdir()
            proc = subprocess.run([sys.executable, blender_ext_cli(), "install-files", path, "--local-dir", str(local),
                                   "--blender-version", blender, "--python-version", python],
                                  capture_output=True, text=True, timeout=120)
            installed = (local / "lapig" / "blender_manifest.toml").is_file()
            if blender == "4.1.1":  # before extensions: refused by the manifest's minimum
                assert not installed, proc.stdout
                assert "doesn't meet the minimum supported version (4.2.0)" in proc.stdout, proc.stdout
            else:
                assert installed, (tag, blender, proc.stdout + proc.stderr)
