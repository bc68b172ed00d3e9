# SPDX-License-Identifier: GPL-3.0-or-later
"""Closing: `with thing:` closes it on the way out (the devices, cameras and windows a capture holds)."""


class Closing:
    def close(self) -> None:
        """Release the device; called on success, error and cancel alike."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class BuiltOnEnter(Closing):
    """`with thing:` builds it (_build) and closes it on the way out; a build that fails (or is interrupted) part way
    is closed at once, so what it had changed is put back (the Cycles studios' temporary scenes)."""

    def _build(self) -> None:
        """Make what the thing holds while it is open."""

    def __enter__(self):
        try:
            self._build()
        except BaseException:
            self.close()
            raise
        return self
