# SPDX-License-Identifier: GPL-3.0-or-later
"""A shot on demand for a tethered camera: gphoto2 takes a picture into the watched folder.

Give a GphotoTrigger as TetheredFolderCamera's ``trigger``: each grab() takes a picture, then waits
for its file. gphoto2 (libgphoto2's command line) must be on PATH and the camera on USB, not
claimed by another program.
"""
from __future__ import annotations

import shutil
import subprocess
import time
from pathlib import Path

from . import RigError


class GphotoTrigger:
    """Takes one picture into ``folder`` with gphoto2 each call (the camera on USB, gphoto2 on PATH).

    Files are named PREFIX_00001.<ext>, PREFIX_00002.<ext>, ... so their names sort in shot order."""

    def __init__(self, folder, executable: str = "gphoto2", timeout_s: float = 60.0,
                 camera: str | None = None, port: str | None = None, prefix: str | None = None):
        self.folder = Path(folder)
        self.executable = executable
        self.timeout_s = float(timeout_s)
        self.camera = camera
        self.port = port
        self.prefix = prefix or time.strftime("lapig_%Y%m%d_%H%M%S")
        self.shots = 0

    @staticmethod
    def available(executable: str = "gphoto2") -> bool:
        return shutil.which(executable) is not None

    def command(self, number: int) -> list[str]:
        """gphoto2's arguments for shot ``number`` (its --filename pattern: '%' escaped, %C the suffix)."""
        pattern = str(self.folder / f"{self.prefix}_{number:05d}").replace("%", "%%") + ".%C"
        command = [self.executable]
        if self.camera:
            command += ["--camera", self.camera]
        if self.port:
            command += ["--port", self.port]
        return command + ["--capture-image-and-download", "--force-overwrite", "--filename", pattern]

    def __call__(self) -> None:
        executable = shutil.which(self.executable)
        if executable is None:
            raise RigError(f"gphoto2 is not installed ({self.executable!r} is not on PATH): install gphoto2, "
                           f"or leave the trigger unset and shoot from the tethering program")
        command = self.command(self.shots + 1)
        command[0] = executable
        try:
            run = subprocess.run(command, capture_output=True, text=True, timeout=self.timeout_s)
        except subprocess.TimeoutExpired:
            raise RigError(f"gphoto2 took no picture within {self.timeout_s:g} s: is the camera on, awake and "
                           f"connected by USB?") from None
        except OSError as exc:
            raise RigError(f"cannot run gphoto2 ({executable}): {exc}") from exc
        if run.returncode != 0:
            said = " / ".join((run.stderr or run.stdout or "").strip().splitlines()[-3:]) or "nothing"
            raise RigError(f"gphoto2 could not take a picture (exit status {run.returncode}; it said: {said}): "
                           f"check that the camera is on and that no other program (a desktop photo import, "
                           f"gvfs) has claimed it")
        self.shots += 1

    def describe(self) -> dict:
        return {"kind": "gphoto2", "executable": self.executable, "timeout_s": self.timeout_s,
                "shots": self.shots, "command": self.command(self.shots + 1)}
