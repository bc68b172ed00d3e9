# SPDX-License-Identifier: GPL-3.0-or-later
"""Install torch into the Python that Blender runs, as a job (no bpy): the preferences' Install button.

Steps, on the job's worker thread, each one a subprocess of Blender's own Python (sys.executable):
1. pip: `python -m pip --version`; where it is missing, `python -m ensurepip --upgrade` (then `--user`, for a
   Blender installed where its folder is read-only).
2. `pip install --target STAGING torch==2.13.0` from the build's index (or a wheel file from disk with
   --no-index), STAGING a fresh folder inside the target; pip's raw progress lines move the progress bar.
3. A fresh Python imports torch from STAGING and says its version: a torch that does not import is not installed.
4. Only then are STAGING's folders renamed into the target (torch's own package last), so a cancel or a
   failure at any step before leaves the target as it was, with no half-installed torch in it.
5. The running session imports it (the target first on sys.path, as Blender puts it at the next start), unless
   this session has imported a torch already: then the panel says to restart Blender.

The target is the user's scripts/modules folder (bpy.utils.user_resource('SCRIPTS', path='modules')): Blender
puts it on sys.path at every start, before the extensions' wheels; it is the user's own (no write access to
Blender's installation needed) and an update or a reinstall of the extension leaves it in place.
Cancel stops pip's whole process group and removes STAGING.
"""
from __future__ import annotations

import importlib
import os
import queue
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field

from ..jobs import JobCancelled, WorkerJob
from .torch_builds import Build, index_args, requirement

STAGING_PREFIX = ".lapig-torch-staging-"
TRASH_PREFIX = ".lapig-torch-old-"
ONLINE_OFF = ("Online access is off in Blender: allow it in Preferences > System > Network (Allow Online Access), "
              "or install torch from a wheel file on disk")
_TAIL_LINES = 40


class TorchInstallError(ValueError):
    """The install failed for a reason worded for the user (errors.one_line shows it as it is)."""


@dataclass
class InstallPlan:
    """What to install, with which Python, where."""
    python: str  # the Python that Blender runs (sys.executable)
    target: str  # the folder torch goes into (the user's scripts/modules)
    source: list  # pip's arguments: where from and what (requirement or wheel file)
    label: str  # 'CPU', 'NVIDIA CUDA 12.8', 'torch-2.13.0-....whl'
    env: dict | None = None  # the subprocesses' environment (None: this process's)
    activate: bool = True  # import the new torch in this session once installed (False: the next start only)


def plan_from_index(python: str, target: str, chosen: Build, env: dict | None = None) -> InstallPlan:
    source = index_args(chosen, os.environ if env is None else env) + [requirement()]
    return InstallPlan(python, target, source, chosen.label, env)


def plan_from_wheel(python: str, target: str, wheel: str, env: dict | None = None) -> InstallPlan:
    """A torch wheel on disk (downloaded elsewhere with `pip download torch==2.13.0 -d FOLDER`): pip looks for
    its dependencies in the same folder only, and never online."""
    wheel = os.path.abspath(os.path.expanduser(wheel or ""))
    name = os.path.basename(wheel)
    if not name.endswith(".whl"):
        raise TorchInstallError(f"'{name or wheel}' is not a wheel file: choose a torch-2.13.0-....whl")
    if not name.lower().startswith("torch-"):
        raise TorchInstallError(f"'{name}' is not a torch wheel (its name starts 'torch-')")
    if not os.path.isfile(wheel):
        raise TorchInstallError(f"no wheel file at {wheel}")
    return InstallPlan(python, target, ["--no-index", "--find-links", os.path.dirname(wheel), wheel], name, env)


OFFLINE_MODE = ("Blender was started offline (--offline-mode): start it without that option to download torch, "
                "or install torch from a wheel file on disk")


def online_refusal(online_access: bool, from_wheel: bool = False, overridden: bool = False) -> str:
    """Why the install may not run ('' when it may): downloading needs Blender's online access (a wheel file
    from disk needs none). overridden: the command line set it (bpy.app.online_access_override), so the
    preference cannot turn it on."""
    if online_access or from_wheel:
        return ""
    return OFFLINE_MODE if overridden else ONLINE_OFF


# ------------------------------------------------------------------------------------- pip's output, as progress

@dataclass
class PipProgress:
    """pip's output lines (with --progress-bar raw) as the job's progress within [start, end]."""
    start: float = 0.15
    end: float = 0.85
    fraction: float = 0.0
    message: str = "asking the package index"
    _file: str = field(default="", repr=False)

    def feed(self, line: str) -> tuple[float, str] | None:
        line = line.strip()
        if m := re.match(r"Progress (\d+) of (\d+)", line):
            done, total = int(m.group(1)), int(m.group(2))
            if total > 0:
                part = done / total
                self.fraction = max(self.fraction, 0.1 + 0.8 * part)  # the first download is torch's, the big one
                self.message = f"downloading {self._file or 'torch'}: {part:.0%} of {total / 1e6:.0f} MB"
        elif m := re.match(r"(?:Collecting|Requirement already satisfied:)\s+(\S+)", line):
            self.message = f"looking for {m.group(1)}"
            self.fraction = max(self.fraction, 0.05)
        elif m := re.match(r"Downloading\s+(\S+)", line):
            self._file = os.path.basename(m.group(1).split("#")[0])
            self.message = f"downloading {self._file}"
        elif m := re.match(r"Processing\s+(\S+)", line):
            self.message = f"reading {os.path.basename(m.group(1))}"
            self.fraction = max(self.fraction, 0.5)
        elif line.startswith("Installing collected packages"):
            self.fraction, self.message = max(self.fraction, 0.92), "unpacking the packages"
        elif line.startswith("Successfully installed"):
            self.fraction, self.message = 1.0, "installed"
        else:
            return None
        return self.start + (self.end - self.start) * self.fraction, self.message


# ------------------------------------------------------------------------------------------------ subprocesses

@dataclass
class Ran:
    returncode: int
    tail: list  # the last lines of its output

    def error_line(self) -> str:
        """pip's own reason (its last 'ERROR:' line), else the last line it wrote."""
        errors = [line for line in self.tail if line.startswith("ERROR:") or "Error:" in line]
        return (errors or self.tail or [f"exit status {self.returncode}"])[-1].strip()


def _popen(cmd, env):
    kwargs = {}
    if os.name == "posix":
        kwargs["start_new_session"] = True  # its own process group: a cancel stops pip and whatever pip started
    else:
        kwargs["creationflags"] = subprocess.CREATE_NEW_PROCESS_GROUP | getattr(subprocess, "CREATE_NO_WINDOW", 0)
    env = dict(os.environ if env is None else env, PYTHONUNBUFFERED="1", PYTHONIOENCODING="utf-8")
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            text=True, encoding="utf-8", errors="replace", env=env, **kwargs)


def stop_process_group(proc, grace_s: float = 5.0):
    """End the process and everything it started; returns once it has exited."""
    if proc.poll() is not None:
        return
    try:
        if os.name == "posix":
            os.killpg(proc.pid, signal.SIGTERM)
        else:
            subprocess.run(["taskkill", "/T", "/F", "/PID", str(proc.pid)], capture_output=True)
        proc.wait(grace_s)
    except subprocess.TimeoutExpired:  # it ignored the request: no more asking
        if os.name == "posix":
            os.killpg(proc.pid, signal.SIGKILL)
        else:
            proc.kill()
        proc.wait()
    except ProcessLookupError:
        proc.wait()


def run_streaming(cmd, env, cancel_event, on_line=None, timeout_s: float | None = None) -> Ran:
    """Run cmd, handing each output line to on_line as it comes; a cancel (or the timeout) stops its process
    group, and a cancel raises JobCancelled."""
    proc = _popen(cmd, env)
    lines = queue.Queue()
    reader = threading.Thread(target=lambda: [lines.put(line) for line in proc.stdout] and None,
                              name="LAPIG: torch install output", daemon=True)
    reader.start()
    tail, started = [], time.monotonic()
    try:
        while reader.is_alive() or not lines.empty():
            if cancel_event.is_set():
                raise JobCancelled()
            if timeout_s is not None and time.monotonic() - started > timeout_s:
                tail.append(f"stopped after {timeout_s:.0f} s")
                break
            try:
                line = lines.get(timeout=0.1)
            except queue.Empty:
                continue
            tail = (tail + [line.rstrip()])[-_TAIL_LINES:]
            if on_line is not None:
                on_line(line)
        else:  # its output has ended: it exits now, on its own (a stop here would turn a success into a failure)
            while proc.poll() is None:
                if cancel_event.is_set():
                    raise JobCancelled()
                time.sleep(0.05)
    finally:
        stop_process_group(proc)  # a cancel or the timeout: pip and what it started; nothing where it has exited
        reader.join(5)
        proc.stdout.close()
    return Ran(proc.wait(), tail)


# ---------------------------------------------------------------------------------------------------- the steps

def pip_version(python: str, env, cancel_event) -> tuple | None:
    """pip's version in `python` ((24, 2)), or None where it has no pip."""
    ran = run_streaming([python, "-m", "pip", "--version"], env, cancel_event, timeout_s=120)
    match = re.search(r"^pip (\d+)\.(\d+)", "\n".join(ran.tail), re.MULTILINE)
    return (int(match.group(1)), int(match.group(2))) if ran.returncode == 0 and match else None


def bootstrap_pip(python: str, env, cancel_event, report) -> tuple:
    """pip in `python`, from its ensurepip where it has none; its version. Raises TorchInstallError with what to
    do where neither is there (Debian's Python without python3-pip)."""
    version = pip_version(python, env, cancel_event)
    if version:
        return version
    report(0.05, "Blender's Python has no pip: installing it (ensurepip)")
    tried = []
    for extra in ([], ["--user"]):  # into Blender's Python; where its folder is read-only, the user's site
        ran = run_streaming([python, "-m", "ensurepip", "--upgrade", *extra], env, cancel_event, timeout_s=600)
        tried.append(ran)
        if ran.returncode == 0 and (version := pip_version(python, env, cancel_event)):
            return version
        if "No module named ensurepip" in "\n".join(ran.tail) or "ensurepip is disabled" in "\n".join(ran.tail):
            break
    raise TorchInstallError(
        f"Blender's Python ({python}) has no pip and could not get one from ensurepip "
        f"({tried[-1].error_line()}): install pip for it (Debian, Ubuntu: sudo apt install python3-pip), "
        f"then press Install torch again")


def pip_install_command(python: str, staging: str, source: list, pip: tuple) -> list:
    progress = "raw" if pip >= (24, 1) else "off"  # raw: 'Progress N of M' lines (pip 24.1 and later)
    return [python, "-m", "pip", "install", "--upgrade", "--target", staging, "--progress-bar", progress,
            "--no-input", "--disable-pip-version-check", "--no-warn-script-location", "--retries", "2", *source]


CHECK_SCRIPT = ("import sys; sys.path.insert(0, sys.argv[1]); import torch; "
                "print('LAPIG-TORCH', torch.__version__, torch.__file__)")


def check_import(python: str, folder: str, env, cancel_event) -> str:
    """A fresh Python imports torch from `folder`: its version. Raises TorchInstallError where it does not."""
    ran = run_streaming([python, "-c", CHECK_SCRIPT, folder], env, cancel_event, timeout_s=600)
    said = next((line for line in ran.tail if line.startswith("LAPIG-TORCH ")), "")
    if ran.returncode != 0 or not said:
        raise TorchInstallError(f"torch was downloaded but does not import: {ran.error_line()}")
    version, where = said.split(" ", 2)[1:]
    if not os.path.abspath(where).startswith(os.path.abspath(folder) + os.sep):
        raise TorchInstallError(f"the check imported another torch ({where}), not the one installed")
    return version


def _project(dist_info: str) -> str:
    """'typing_extensions-4.12.2.dist-info' -> 'typing-extensions' (the names pip may spell either way)."""
    return re.sub(r"[-_.]+", "-", dist_info.removesuffix(".dist-info").split("-", 1)[0]).lower()


def move_into_target(staging: str, target: str) -> list[str]:
    """Rename what pip put in `staging` into `target`: what it replaces (and older .dist-info of the same
    projects) goes aside first, torch's own package last, so torch/ appears only when all it needs is there.
    Returns the names moved."""
    names = sorted(os.listdir(staging), key=lambda n: (n in ("torch", "bin"), n == "torch", n))
    trash = tempfile.mkdtemp(prefix=TRASH_PREFIX, dir=target)
    new_projects = {_project(n) for n in names if n.endswith(".dist-info")}
    for old in os.listdir(target):
        if old.endswith(".dist-info") and _project(old) in new_projects and old not in names:
            os.replace(os.path.join(target, old), os.path.join(trash, old))
    for name in names:
        source, dest = os.path.join(staging, name), os.path.join(target, name)
        if name == "bin" and os.path.isdir(dest):  # scripts of other packages live there too: merge, file by file
            for script in os.listdir(source):
                os.replace(os.path.join(source, script), os.path.join(dest, script))
            continue
        if os.path.lexists(dest):
            os.replace(dest, os.path.join(trash, name))
        os.replace(source, dest)
    shutil.rmtree(trash, ignore_errors=True)  # a loaded DLL of an old torch (Windows) stays: remove_leftovers
    return names


def remove_leftovers(target: str, older_than_s: float = 3600.0):
    """Staging and old folders a crash or a locked file left in the target; only old ones (another Blender may
    be installing into the same folder now)."""
    try:
        names = os.listdir(target)
    except OSError:
        return
    for name in names:
        path = os.path.join(target, name)
        try:
            old = time.time() - os.path.getmtime(path) > older_than_s
        except OSError:
            continue
        if name.startswith((STAGING_PREFIX, TRASH_PREFIX)) and old:
            shutil.rmtree(path, ignore_errors=True)


def activate_in_session(target: str) -> tuple[bool, str]:
    """Make the installed torch importable in this Python now: (True, version) when it imports from target;
    (False, why) where this session needs a restart for it."""
    if "torch" in sys.modules:
        return False, "this session has imported another torch already"
    if target in sys.path:
        sys.path.remove(target)
    sys.path.insert(0, target)  # as Blender puts scripts/modules at the next start: before site-packages
    importlib.invalidate_caches()
    try:
        import torch
    except Exception as exc:  # a library torch needs does not load in Blender: the next start may differ
        for name in [n for n in sys.modules if n == "torch" or n.startswith("torch.")]:
            del sys.modules[name]
        return False, f"torch does not import in this session ({type(exc).__name__}: {exc})"
    where = os.path.abspath(getattr(torch, "__file__", "") or "")
    if not where.startswith(os.path.abspath(target) + os.sep):
        return False, f"this session imports another torch ({where})"
    return True, str(torch.__version__)


@dataclass
class InstallOutcome:
    version: str  # the torch installed
    label: str
    active: bool  # it imports in this session: Train and Generate work now
    why_restart: str = ""  # where not active
    seconds: float = 0.0
    moved: list = field(default_factory=list)

    def line(self) -> str:
        if self.active:
            return f"torch {self.version} ({self.label}) installed: Train and Generate work now"
        return f"torch {self.version} ({self.label}) installed: restart Blender to use it"


class TorchInstallJob(WorkerJob):
    title = "Installing torch"

    def __init__(self, plan: InstallPlan):
        super().__init__()
        self.plan = plan
        self.staging = ""

    def work(self, inputs, report, cancel_event):
        plan, started = self.plan, time.perf_counter()
        report(0.01, "checking pip in Blender's Python")
        pip = bootstrap_pip(plan.python, plan.env, cancel_event, report)
        os.makedirs(plan.target, exist_ok=True)
        remove_leftovers(plan.target)
        self.staging = tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=plan.target)
        try:
            progress = PipProgress()
            report(progress.start, f"installing torch ({plan.label})")

            def on_line(line):
                moved = progress.feed(line)
                if moved is not None:
                    report(*moved)

            ran = run_streaming(pip_install_command(plan.python, self.staging, plan.source, pip), plan.env,
                                cancel_event, on_line)
            if ran.returncode != 0:
                raise TorchInstallError(f"pip could not install torch ({plan.label}): {ran.error_line()}")
            report(0.88, "checking that torch imports")
            version = check_import(plan.python, self.staging, plan.env, cancel_event)
            report(0.95, "moving torch into place")
            if cancel_event.is_set():
                raise JobCancelled()
            moved = move_into_target(self.staging, plan.target)  # quick renames: not cancelled half-way
        finally:
            shutil.rmtree(self.staging, ignore_errors=True)
        active, why = False, "installed for the next start"
        if plan.activate:
            report(0.97, "loading torch in this session")
            active, why = activate_in_session(plan.target)
        return InstallOutcome(version, plan.label, active, "" if active else why,
                              round(time.perf_counter() - started, 2), moved)


class InstallSlot:
    """The one torch install of a session (it runs beside LAPIG's jobs: Capture needs no torch), and what the
    last one said, for the preferences and the panels."""

    def __init__(self):
        self.job: TorchInstallJob | None = None
        self.outcome: InstallOutcome | None = None
        self.failure = ""  # the last install's failure, one line

    def running(self) -> bool:
        return self.job is not None and not self.job.finished

    def start(self, job: TorchInstallJob) -> str:
        """Take the slot; why not ('' when taken)."""
        if self.running():
            return "torch is being installed already: wait for it, or Cancel it"
        self.job, self.failure = job, ""
        return ""

    def ended(self, job: TorchInstallJob):
        """The job ended: keep what the panel says of it."""
        if job.state == "DONE":
            self.outcome, self.failure = job.result, ""
        elif job.state == "FAILED":
            self.failure = f"Installing torch failed: {job.message}"
        elif job.state == "CANCELLED":
            self.failure = "Installing torch was cancelled: nothing was changed"

    def restart_needed(self) -> bool:
        return self.outcome is not None and not self.outcome.active

    def cancel(self) -> bool:
        if not self.running():
            return False
        self.job.cancel()  # the worker stops pip's processes and removes its staging folder
        self.ended(self.job)
        return True


SLOT = InstallSlot()
