# SPDX-License-Identifier: GPL-3.0-or-later
"""Closed-loop refinement of a projector image on the rig, at the working frame or of the native output
(loop), and its registration check (check). numpy and OpenCV only."""
