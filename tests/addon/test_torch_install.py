"""The preferences' Install torch, without Blender: pip installs a fake torch wheel from a local index (or a wheel
file) into a target folder with a real pip in a subprocess, bootstraps pip with ensurepip where there is none,
stops pip's processes on a cancel and leaves the target as it was, and refuses to go online where Blender may not."""
import os
import subprocess
import sys
import time

import pytest

from lapig.tools.bench.fake_torch_index import FAKE_VERSION, LocalIndex, isolated_pip_env, make_fake_torch_wheel
from lapig.lapig_addon.services.install import torch_builds, torch_install
from lapig.lapig_addon.services.install.torch_install import (InstallPlan, PipProgress, TorchInstallJob, plan_from_index, plan_from_wheel)


@pytest.fixture
def wheel(tmp_path):
    return make_fake_torch_wheel(tmp_path / "wheels")


@pytest.fixture
def pip_env(tmp_path):
    return isolated_pip_env(tmp_path / "pip-cache")


def _run(job):
    job.poll_timeout = 0.05
    job.run()
    return job


def _no_torch_left(target):
    return not any(name == "torch" or name.startswith(torch_install.STAGING_PREFIX) for name in os.listdir(target))


def test_each_platform_has_its_builds_and_each_build_its_index():
    assert [b.key for b in torch_builds.builds_for("linux")] == ["CPU", "CUDA128", "CUDA130", "ROCM"]
    assert [b.key for b in torch_builds.builds_for("win32")] == ["CPU", "CUDA128", "CUDA130"]
    assert [b.key for b in torch_builds.builds_for("darwin")] == ["MAC"]
    assert torch_builds.default_build("linux", nvidia_gpu=True) == "CUDA128"
    assert torch_builds.default_build("win32") == "CPU" and torch_builds.default_build("darwin") == "MAC"
    cpu = torch_builds.build("CPU")
    assert torch_builds.index_args(cpu, {}) == ["--index-url", "https://download.pytorch.org/whl/cpu"]
    assert torch_builds.index_args(torch_builds.build("MAC"), {}) == []  # the ordinary index: pip's own settings
    mirror = {torch_builds.INDEX_ENV: "http://mirror/simple/"}
    assert torch_builds.index_args(cpu, mirror) == ["--index-url", "http://mirror/simple/"]
    plan = plan_from_index("py", "/t", torch_builds.build("CUDA128"), env={})
    assert plan.source == ["--index-url", "https://download.pytorch.org/whl/cu128", "torch==2.13.0"]
    assert "Intel Macs" in torch_builds.unsupported_reason("darwin", "x86_64")
    assert torch_builds.unsupported_reason("darwin", "arm64") == ""
    with pytest.raises(ValueError, match="no torch build 'TPU'"):
        torch_builds.build("TPU")


def test_pips_raw_progress_moves_the_bar_and_says_what_it_downloads():
    progress = PipProgress(start=0.0, end=1.0)
    assert progress.feed("Looking in indexes: http://x") is None
    assert progress.feed("Collecting torch==2.13.0")[1] == "looking for torch==2.13.0"
    progress.feed("  Downloading http://x/files/torch-2.13.0%2Bcpu-cp313-cp313-linux_x86_64.whl (190.0 MB)")
    half = progress.feed("Progress 95000000 of 190000000")
    assert half[0] == pytest.approx(0.5) and "50% of 190 MB" in half[1] and "torch-2.13.0" in half[1]
    assert progress.feed("Progress 1000 of 190000000")[0] == pytest.approx(0.5)  # the next file: never backwards
    assert progress.feed("Installing collected packages: torch")[0] == pytest.approx(0.92)


def test_the_button_refuses_to_go_online_where_blender_may_not():
    refusal = torch_install.online_refusal(False)
    assert "Preferences > System > Network" in refusal and "wheel file" in refusal
    assert torch_install.online_refusal(True) == "" and torch_install.online_refusal(False, from_wheel=True) == ""
    assert "--offline-mode" in torch_install.online_refusal(False, overridden=True)  # the preference cannot help


def test_install_from_the_local_index_checks_the_import_and_moves_torch_into_place(tmp_path, pip_env):
    wheel = make_fake_torch_wheel(tmp_path / "wheels", padding_bytes=2_000_000)  # big enough for pip's progress
    target = tmp_path / "modules"
    target.mkdir()
    (target / "torch-2.12.0.dist-info").mkdir()  # an older torch's record, which the new one replaces
    with LocalIndex(wheel, send_seconds=1.0) as index:
        pip_env[torch_builds.INDEX_ENV] = index.url
        plan = plan_from_index(sys.executable, str(target), torch_builds.build("CPU"), env=pip_env)
        plan.activate = False  # this test's Python may have imported a real torch: the bpy tier tests that step
        seen = []
        job = TorchInstallJob(plan)
        job.poll_timeout = 0.05
        while job.step():
            seen.append(job.message)
    assert job.state == "DONE", job.message
    assert index.wheel_requested.is_set()
    outcome = job.result
    assert outcome.version == FAKE_VERSION and not outcome.active and "restart Blender" in outcome.line()
    assert (target / "torch" / "version.py").read_text().startswith(f"__version__ = '{FAKE_VERSION}'")
    assert not (target / "torch-2.12.0.dist-info").exists() and (target / f"torch-{FAKE_VERSION}.dist-info").is_dir()
    assert not [n for n in os.listdir(target) if n.startswith(".lapig-torch-")]  # staging and the old one: gone
    assert "checking that torch imports" in seen and any(m.startswith("installing torch (CPU)") for m in seen)
    assert any(m.startswith(f"downloading torch-{FAKE_VERSION}-py3-none-any.whl: ") and m.endswith("of 2 MB")
               for m in seen), seen  # pip's raw progress, read as it comes
    found = subprocess.run([sys.executable, "-c", torch_install.CHECK_SCRIPT, str(target)], capture_output=True,
                           text=True, env=pip_env)
    assert found.stdout.startswith(f"LAPIG-TORCH {FAKE_VERSION} {target}"), found.stderr


def test_a_wheel_file_from_disk_installs_without_any_index(tmp_path, wheel, pip_env):
    target = tmp_path / "modules"
    plan = plan_from_wheel(sys.executable, str(target), wheel, env=pip_env)
    assert plan.source[:2] == ["--no-index", "--find-links"]
    plan.activate = False
    job = _run(TorchInstallJob(plan))
    assert job.state == "DONE", job.message
    assert job.result.version == FAKE_VERSION and (target / "torch" / "__init__.py").is_file()
    with pytest.raises(ValueError, match="not a wheel file"):
        plan_from_wheel(sys.executable, str(target), str(tmp_path / "torch.zip"))
    with pytest.raises(ValueError, match="no wheel file at"):
        plan_from_wheel(sys.executable, str(target), str(tmp_path / "torch-2.13.0-py3-none-any.whl"))


@pytest.mark.skipif(not os.path.isdir("/proc"), reason="finds pip's processes in /proc (Linux)")
def test_a_cancel_mid_download_stops_pip_and_leaves_the_target_as_it_was(tmp_path, wheel, pip_env):
    target = tmp_path / "modules"
    with LocalIndex(wheel, hold=True) as index:
        pip_env[torch_builds.INDEX_ENV] = index.url
        job = TorchInstallJob(plan_from_index(sys.executable, str(target), torch_builds.build("CPU"), env=pip_env))
        job.poll_timeout = 0.05
        deadline = time.monotonic() + 120
        while not index.wheel_requested.is_set():  # pip waits for the wheel's bytes now
            assert job.step() and time.monotonic() < deadline, job.message
        pips = _pip_processes(job.staging)
        assert pips, "no pip process installs into the staging folder"
        job.stop()  # the panel's Cancel, waiting here for the worker to finish its cleanup
    assert job.state == "CANCELLED"
    assert not [pid for pid in pips if _alive(pid)], "pip still runs after the cancel"
    assert _no_torch_left(target)


def _pip_processes(staging: str) -> list[int]:
    """The processes whose command line names the staging folder (pip install --target STAGING)."""
    found = []
    for pid in os.listdir("/proc"):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                if staging.encode() in f.read():
                    found.append(int(pid))
        except OSError:
            continue
    return found


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ")[1][0] != "Z"
    except OSError:
        return False


def test_a_python_without_pip_gets_it_from_ensurepip_then_installs(tmp_path, wheel, pip_env):
    venv = tmp_path / "nopip"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = str(venv / ("Scripts/python.exe" if os.name == "nt" else "bin/python"))
    assert subprocess.run([python, "-m", "pip", "--version"], capture_output=True).returncode != 0
    target = tmp_path / "modules"
    plan = plan_from_wheel(python, str(target), wheel, env=pip_env)
    plan.activate = False
    seen = []
    job = TorchInstallJob(plan)
    job.poll_timeout = 0.05
    while job.step():
        seen.append(job.message)
    assert job.state == "DONE", job.message
    assert any("ensurepip" in m for m in seen)
    assert subprocess.run([python, "-m", "pip", "--version"], capture_output=True).returncode == 0
    assert job.result.version == FAKE_VERSION


@pytest.mark.skipif(os.name == "nt", reason="the stand-in Python is a script with a #! line")
def test_a_python_without_pip_nor_ensurepip_says_what_to_install(tmp_path, wheel, pip_env):
    fake = tmp_path / "python"  # Debian's Python without python3-pip: both modules missing
    fake.write_text(f"#!{sys.executable}\nimport sys\nprint(f'/usr/bin/python: No module named {{sys.argv[2]}}')\n"
                    "sys.exit(1)\n")
    fake.chmod(0o755)
    job = _run(TorchInstallJob(plan_from_wheel(str(fake), str(tmp_path / "modules"), wheel, env=pip_env)))
    assert job.state == "FAILED"
    assert "has no pip" in job.message and "sudo apt install python3-pip" in job.message


def test_pip_failing_says_pips_reason_and_leaves_nothing(tmp_path, wheel, pip_env):
    target = tmp_path / "modules"
    with LocalIndex(wheel) as index:
        pip_env[torch_builds.INDEX_ENV] = index.url
        plan = InstallPlan(sys.executable, str(target), ["--index-url", index.url, "torch==9.9.9"], "CPU", pip_env)
        job = _run(TorchInstallJob(plan))
    assert job.state == "FAILED"
    assert job.message.startswith("pip could not install torch (CPU): ERROR:") and "torch==9.9.9" in job.message
    assert _no_torch_left(target)
