# SPDX-License-Identifier: GPL-3.0-or-later
"""Pictures of still frames before the frame code can verify any: the rig's calibration (finding the
code's cells) needs them, and a camera that drops, repeats or tears frames must not fool it.

A picture is kept once three grabs of the frame agree on it: one bad grab cannot make a pair with the
next one, and good grabs of an earlier try still count. Of a cell lit alone it must also differ from the
previous frame's picture (a late, repeated or torn grab shows that one) and not be darker than black's (a
dropped grab is black). Of the black frame it is the picture most of several grabs agree on. The share of grabs that agreed with nothing says whether the camera's frames
can be verified at all.
"""
from __future__ import annotations

import numpy as np

from . import RigError
from . import frame_code as fc

TRIES = 6  # waits, each longer: a camera later than measured
GRABS_PER_TRY = 4
BLACK_GRABS = 12
FAULTY_SHARE = 0.05  # of grabs agreeing with nothing: the frames cannot be verified above this


class StillPictures:
    def __init__(self, output, camera, clock, settle_s: float):
        self.output, self.camera, self.clock, self.settle_s = output, camera, clock, settle_s
        self.grabs = self.outliers = 0
        self.previous = None

    def faulty_share(self) -> float:
        return self.outliers / max(self.grabs, 1)

    def black(self, frame) -> np.ndarray:
        """The picture of ``frame`` (a black one) that most of several grabs agree on."""
        shown = self.output.show(frame)
        pictures = []
        for attempt in range(TRIES):
            self._wait(shown, attempt)
            pictures += [self._grab() for _ in range(BLACK_GRABS if attempt == 0 else GRABS_PER_TRY)]
            votes = [_agreeing(pictures, i) for i in range(len(pictures))]
            if max(votes) >= 2:  # the picture most grabs agree on; of equals, the darkest
                best = min(range(len(pictures)), key=lambda i: (-votes[i], _level(pictures[i])))
                return self._keep(pictures[best], pictures)
        return self._give_up(pictures)

    def lit(self, frame, black: np.ndarray) -> np.ndarray:
        """The agreed picture of ``frame`` (a code cell lit alone), new since the previous one."""
        shown = self.output.show(frame)
        pictures = []
        for attempt in range(TRIES):
            self._wait(shown, attempt)
            for _ in range(GRABS_PER_TRY):
                pictures.append(self._grab())
                kept = _agreed_picture(pictures, self.previous, black, stays=attempt >= 2)
                if kept is not None:
                    return self._keep(kept, pictures)
        return self._give_up(pictures)

    def _wait(self, shown: float, attempt: int) -> None:
        self.clock.sleep_until(shown + 2 * self.settle_s * (attempt + 1))

    def _grab(self) -> np.ndarray:
        self.camera.flush()
        self.grabs += 1
        return self.camera.grab()[0]

    def _keep(self, picture, pictures):
        self.outliers += sum(not _agree(picture, p) for p in pictures)
        self.previous = picture
        return picture

    def _give_up(self, pictures):
        self.outliers += len(pictures)
        if self.faulty_share() > FAULTY_SHARE:
            raise RigError(self.unverifiable())
        raise RigError("the camera's pictures of the same still frame keep changing: its auto exposure or auto "
                       "gain is probably on (lock them), or the camera moves, or its cable is loose")

    def unverifiable(self) -> str:
        return (f"the camera's frames cannot be verified: {self.faulty_share():.0%} of its pictures of still "
                "frames were dropped, repeated or torn, and the frame code at the projection's top and bottom "
                "edges could not be read in them: check the camera's cable, its frame rate and the light, and "
                "that it sees both edges of the projection")


def _agreed_picture(pictures: list, previous=None, black=None, stays: bool = False):
    """A picture two others of ``pictures`` agree with, not darker than ``black``, that differs from
    ``previous`` (or, once it ``stays`` so, is black's: a cell the camera does not see); None."""
    for i, candidate in enumerate(pictures):
        if previous is not None and _agree(previous, candidate) and not (stays and _agree(black, candidate)):
            continue
        if _level(candidate) < _level(black) - 0.02:  # a dropped grab: nothing shown is darker than black
            continue
        if _agreeing(pictures, i) >= 2:
            return candidate
    return None


def _agreeing(pictures: list, i: int) -> int:
    return sum(_agree(pictures[i], other) for j, other in enumerate(pictures) if j != i)


def _level(picture) -> float:
    return float(fc.luma(picture).mean())


def _agree(a, b, change: float = 0.15, pixels: int = 8) -> bool:
    """Two camera pictures of the same frame: fewer than ``pixels`` pixels changed by more than ``change``
    (a single code cell lights only a few hundred pixels, so a share would miss it)."""
    return int((np.abs(fc.luma(a) - fc.luma(b)) > change).sum()) < pixels
