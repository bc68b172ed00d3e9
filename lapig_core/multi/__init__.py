# SPDX-License-Identifier: GPL-3.0-or-later
"""Several projectors on one object (issue 36), numpy + OpenCV only: the joint classical model in camera
space, its box-constrained compensation, geometric blend weights, the black level of overlaps, coverage,
and a numpy fake rig of K projectors and one camera for tests."""
