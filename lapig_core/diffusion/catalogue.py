# SPDX-License-Identifier: GPL-3.0-or-later
"""The diffusion models the add-on supports: which repository, what it does, its licence.

Sizes are not written here: the repository's listing gives them (the manager shows them once it has listed the
files, and the download's total before it starts). Licences are as each repository's model card states them;
the user accepts them on the model's page, never here.
"""
from __future__ import annotations

from dataclasses import dataclass


class ModelError(ValueError):
    """A model refused for a reason worded for the user: one line, its message is the whole story."""


@dataclass(frozen=True)
class CatalogueModel:
    key: str  # the add-on's name for it: folder name, operator argument
    repo_id: str  # the Hugging Face repository
    title: str
    kind: str  # 'ip2p' (instruction editing, StableDiffusionInstructPix2PixPipeline), 'img2img' (one-step)
    licence: str
    licence_url: str
    purpose: str
    gated: bool = False  # needs a token and the licence accepted on its page

    @property
    def page(self) -> str:
        return f"https://huggingface.co/{self.repo_id}"


CATALOGUE = (
    CatalogueModel(
        key="instruct-pix2pix", repo_id="timbrooks/instruct-pix2pix", title="InstructPix2Pix", kind="ip2p",
        licence="MIT (the model card's licence field)", licence_url="https://huggingface.co/timbrooks/instruct-pix2pix",
        purpose="edits the surface as the prompt instructs (the LAPIG paper's model), 10 steps"),
    CatalogueModel(
        key="sd-turbo", repo_id="stabilityai/sd-turbo", title="SD-Turbo", kind="img2img",
        licence="Stability AI's own licence (its LICENSE file; commercial use: stability.ai/license)",
        licence_url="https://huggingface.co/stabilityai/sd-turbo/blob/main/LICENSE",
        purpose="one-step image-to-image (distilled from Stable Diffusion 2.1): previews in a fraction of a second "
                "on a GPU"),
)
# A depth-conditioned model is not listed: the depth ControlNets are for Stable Diffusion 1.5 or 2.1 bases of their
# own (another 1.5-5 GB and another licence), and the geometry conditioning that would use one is not built yet.


def keys() -> list[str]:
    return [m.key for m in CATALOGUE]


def model(key: str) -> CatalogueModel:
    """The catalogue's model by key (or by its repository id); ModelError naming the choices otherwise."""
    for entry in CATALOGUE:
        if key in (entry.key, entry.repo_id):
            return entry
    raise ModelError(f"unknown model '{key}': the add-on supports {', '.join(keys())}")
