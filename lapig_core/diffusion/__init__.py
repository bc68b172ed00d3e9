# SPDX-License-Identifier: GPL-3.0-or-later
"""Diffusion models the user installs: the catalogue, downloads from a Hugging Face-style hub, the folder checks,
and where (and in which precision) a model can run. No bpy, no torch at import (the device check imports it
lazily): the preferences list the models on machines without either."""
