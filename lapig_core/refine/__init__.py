# SPDX-License-Identifier: GPL-3.0-or-later
"""Closed-loop refinement of a projector image on the rig (loop), its registration check (check) and
its correction carried to the native output (native). numpy and OpenCV only."""
