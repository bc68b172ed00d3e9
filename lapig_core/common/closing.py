# SPDX-License-Identifier: GPL-3.0-or-later
"""Closing: `with thing:` closes it on the way out (the devices, cameras and windows a capture holds)."""


class Closing:
    def close(self) -> None:
        """Release the device; called on success, error and cancel alike."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
