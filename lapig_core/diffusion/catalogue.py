# SPDX-License-Identifier: GPL-3.0-or-later
"""The diffusion models the add-on supports: which repository, what it does, its licence.

Sizes are not written here: the repository's listing gives them (the manager shows them once it has listed the
files, and the download's total before it starts); size_hint is what the model's page listed, shown while the
model is absent. Licences are as each repository's model card states them; the user accepts them on the model's
page, never here.
"""
from __future__ import annotations

from dataclasses import dataclass


class ModelError(ValueError):
    """A model refused for a reason worded for the user: one line, its message is the whole story."""


PIPELINE, MODEL = "pipeline", "model"  # a diffusers pipeline folder; one diffusers model (an adapter)


@dataclass(frozen=True)
class CatalogueModel:
    key: str  # the add-on's name for it: folder name, operator argument
    repo_id: str  # the Hugging Face repository
    title: str
    kind: str  # 'ip2p' (instruction editing, StableDiffusionInstructPix2PixPipeline), 'img2img' (one-step),
    # 'depth-adapter' (a T2I-Adapter that conditions the InstructPix2Pix UNet on the object's depth)
    licence: str
    licence_url: str
    purpose: str
    gated: bool = False  # needs a token and the licence accepted on its page
    layout: str = PIPELINE  # PIPELINE: model_index.json and its components; MODEL: one network, config.json + weights
    size_hint: str = ""  # what the model's page lists, shown while it is absent ('' : the listing says it)

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
        licence="Stability AI Non-Commercial Research Community License (its LICENSE file: research and "
                "non-commercial use; the model card sends commercial use to stability.ai/license)",
        licence_url="https://huggingface.co/stabilityai/sd-turbo",
        purpose="one-step image-to-image (distilled from Stable Diffusion 2.1): the preview that follows the prompt "
                "as it is typed, in a fraction of a second on a GPU"),
    CatalogueModel(
        key="depth-adapter", repo_id="TencentARC/t2iadapter_depth_sd15v2", title="T2I-Adapter depth (SD 1.5)",
        kind="depth-adapter", layout=MODEL, size_hint="about 309 MB (one weights file)",
        licence="Apache-2.0 (the model card's licence field)",
        licence_url="https://huggingface.co/TencentARC/t2iadapter_depth_sd15v2",
        purpose="makes InstructPix2Pix's drawing follow the object's shape: the object's depth as the projector "
                "sees it conditions every step (no other base model to download)"),
)
# The depth adapter, not a depth ControlNet: lllyasviel's SD 1.5 depth ControlNet (CreativeML OpenRAIL-M) is 1.45 GB
# (723 MB in fp16) and runs beside the UNet at every step, twice the cost of each PSA step; the adapter runs once per
# look, and InstructPix2Pix's UNet is Stable Diffusion 1.5's, the base the adapter was trained on.


def keys() -> list[str]:
    return [m.key for m in CATALOGUE]


def model(key: str) -> CatalogueModel:
    """The catalogue's model by key (or by its repository id); ModelError naming the choices otherwise."""
    for entry in CATALOGUE:
        if key in (entry.key, entry.repo_id):
            return entry
    raise ModelError(f"unknown model '{key}': the add-on supports {', '.join(keys())}")
