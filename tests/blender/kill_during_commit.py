"""`python tests/blender/kill_during_commit.py N capture ...`: the command line, killed (SIGKILL, by
itself) at the rename N + 1 of the capture's commit, when N renames of it are done."""
import os
import pathlib
import signal
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))
from lapig_addon.__main__ import _load_extension_package  # noqa: E402

_load_extension_package()
from lapig.lapig_addon.cli import main  # noqa: E402

renames, done, rename = int(sys.argv[1]), [], pathlib.Path.replace


def replace(self, target):  # the commit's only renames (atomic writes use os.replace)
    if len(done) == renames:
        os.kill(os.getpid(), signal.SIGKILL)
    done.append(self)
    return rename(self, target)


pathlib.Path.replace = replace
sys.exit(main.main(sys.argv[2:]))
