# SPDX-License-Identifier: GPL-3.0-or-later
"""Staging a capture beside its data set and swapping it in at the end.

A capture must never leave old and new files mixed where a setup is expected: not on a cancel,
an error, a crash or a kill. So it writes into <root>/.capture_staging/<setup>/, a data set root
of its own: setups/<setup> and, unless other setups share the root's projector images,
prj/{ref,train,test}. The commit then moves things with renames only:

1. a journal of the moves is written: from here on the staged set is complete;
2. the old setup folder goes to the staging folder's old/, the staged one takes its place;
3. each old prj/<kind> goes to old/, the staged one takes its place;
4. the staging folder (old files and journal) is deleted.

The setup moves before the projector images because its setup.json records the digest of the new
prj images: between any two renames the loader finds the complete old set, the complete new set,
a missing folder, or prj images that do not match the digest, and it refuses the last two.
A kill leaves the journal; the next job that takes the root's lock replays it first.

A capture holds the root's lock (common.locking) from before it clears anything until its commit
is done, and training and generation hold it while they use the root: one job writes into a root
at a time, and whatever staging a job finds there was left by a process that is gone.
"""
from __future__ import annotations

import json
import shutil
from functools import cached_property
from pathlib import Path

import numpy as np

from ..common.atomic import atomic_write_bytes
from ..common.imageio import read_image
from ..common.locking import FolderLock
from . import dataset as ds
from .settings import CaptureError

STAGING_DIR = ".capture_staging"
JOURNAL = "commit.json"


def other_setups(final: ds.DatasetLayout) -> list[str]:
    """The root's setups besides this one: they share its projector images."""
    setups = final.root / "setups"
    if not setups.is_dir():
        return []
    return sorted(p.name for p in setups.iterdir()
                  if p.is_dir() and p.name != final.setup and not p.name.startswith("."))


def check_shared_patterns(final: ds.DatasetLayout, images: dict, others: list[str]) -> None:
    """Refuse to capture beside other setups with projector images other than theirs: replacing
    prj/ would make their captures stop matching."""
    for kind, new in images.items():
        folder = final.prj_dir(kind)
        stored = ds.list_images(folder) if folder.is_dir() else []
        if len(stored) != len(new) or not all(_same_8bit(read_image(p), im) for p, im in zip(stored, new)):
            raise CaptureError(
                f"the folder {final.root} holds other setups ({', '.join(others[:3])}) captured with "
                f"different projector images ({kind}): capture into another folder, or use the same "
                f"patterns, counts, working size and gray level as they did")


def _same_8bit(stored: np.ndarray, image: np.ndarray) -> bool:
    expected = np.round(np.clip(image, 0, 1) * 255) / 255
    return stored.shape == expected.shape and np.abs(stored - expected).max() <= 1 / 255


class StagedCapture:
    """Where a capture writes (``layout``), and the commit that swaps it into ``final``.

    ``with StagedCapture(final, "LAPIG capture") as staged:`` takes the root's lock (FolderBusy,
    naming the job that holds it, when another has it) and tidies the root; leaving the block
    drops an uncommitted staging and the lock.
    """

    def __init__(self, final: ds.DatasetLayout, holder: str):
        self.final = final
        self.folder = final.root / STAGING_DIR / final.setup
        self.layout = ds.DatasetLayout(self.folder, final.setup)
        self._lock = hold_root(final.root, holder)
        # where captures staged before .capture_staging existed
        shutil.rmtree(final.root / "setups" / f"{final.setup}.partial", ignore_errors=True)

    @cached_property
    def others(self) -> list[str]:
        return other_setups(self.final)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        try:
            # what an unfinished capture staged (cancel, error) goes; a commit under way belongs
            # to its journal
            if not (self.folder / JOURNAL).exists():
                _remove_staged(self.folder)
        finally:
            self._lock.release()

    @property
    def owns_projector_images(self) -> bool:
        """Alone in its root, a capture replaces prj/; beside other setups it keeps theirs."""
        return not self.others

    @property
    def projector_layout(self) -> ds.DatasetLayout:
        """Where the projector images of this capture are: staged, or the root's own, kept."""
        return self.layout if self.owns_projector_images else self.final

    def commit(self) -> None:
        root = self.final.root
        moves = self._moves()
        journal = self.folder / JOURNAL
        atomic_write_bytes(journal, json.dumps(moves).encode("utf-8"))
        try:
            _replay(root, moves)
        except BaseException:
            # put the old set back now; if that fails too, the journal stays for the next capture
            _replay(root, [(b, a) for a, b in reversed(moves)])
            journal.unlink()
            raise
        _remove_staged(self.folder)

    def _moves(self) -> list[tuple[str, str]]:
        """(from, to) paths relative to the root, in commit order; only those that exist."""
        staged = self.folder.relative_to(self.final.root)
        old = staged / "old"
        setup = Path("setups") / self.final.setup
        pairs = [(setup, old / setup), (staged / setup, setup)]
        if self.owns_projector_images:
            for kind in ds.PRJ_KINDS:
                prj = Path("prj") / kind
                pairs += [(prj, old / prj), (staged / prj, prj)]
        return [(a.as_posix(), b.as_posix()) for a, b in pairs if (self.final.root / a).exists()]


def _remove_staged(folder: Path) -> None:
    shutil.rmtree(folder, ignore_errors=True)
    try:
        folder.parent.rmdir()  # .capture_staging, when no other setup is staged there
    except OSError:
        pass


def _replay(root: Path, moves) -> None:
    """Do the moves not done yet (source there, destination not): a replay after a kill
    finishes exactly what is left."""
    for source, dest in moves:
        source, dest = root / source, root / dest
        if source.exists() and not dest.exists():
            dest.parent.mkdir(parents=True, exist_ok=True)
            source.replace(dest)


def hold_root(root, holder: str) -> FolderLock:
    """Take the root's lock (FolderBusy, naming the job that has it, when another does), then tidy
    the root: interrupted commits finished, what killed captures staged removed (no live capture
    stages there while the lock is held)."""
    root = Path(root)
    lock = FolderLock(root, holder).acquire()
    try:
        finish_interrupted_commits(root)
        shutil.rmtree(root / STAGING_DIR, ignore_errors=True)
    except BaseException:
        lock.release()
        raise
    return lock


def finish_interrupted_commits(root) -> list[str]:
    """Complete the commits that a crash or a kill interrupted in ``root`` (their staged sets are
    complete); returns their setup names."""
    root = Path(root)
    finished = []
    for journal in sorted((root / STAGING_DIR).glob(f"*/{JOURNAL}")):
        _replay(root, json.loads(journal.read_text(encoding="utf-8")))
        _remove_staged(journal.parent)
        finished.append(journal.parent.name)
    return finished
