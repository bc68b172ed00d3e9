"""A world look as its result records it (result.json's lgst.look_record and lgst.look_parameters): what the
sliders edit (services/generate/look_edit) and what Generate keeps for the same prompt (services/generate/generate_job)."""
from __future__ import annotations

from ....lapig_core.look_parameters import LookParameters

DEFAULT_BACKEND = "styletransfer"  # lapig_core.lgst's (that package loads torch; this module does not)


def world_record(summary: dict) -> tuple[dict, LookParameters] | None:
    """(the look's record, its parameters) of a result of a world look; None for a look of another kind."""
    lgst = summary.get("lgst") or {}
    if summary.get("backend", DEFAULT_BACKEND) != DEFAULT_BACKEND or "multi" in summary:
        return None
    record, values = lgst.get("look_record"), lgst.get("look_parameters")
    if not record or values is None:
        return None
    return record, LookParameters.from_dict(values)


def plan_parameters(record: dict, seed: int) -> LookParameters:
    """The parameters the prompt plan chose (what Reset goes back to)."""
    world = record["world"]
    return LookParameters(scale=float(world.get("scale", 1.0)), density=float(world.get("density", 0.0)),
                          seed=int(seed))


def parameters_for_generate(summary: dict | None, prompt: str, backend: str) -> dict | None:
    """The edited parameters a Generate of the same prompt keeps (the scene's result's); None otherwise."""
    if not summary or backend != DEFAULT_BACKEND or (summary.get("prompt") or "").strip() != prompt.strip():
        return None
    found = world_record(summary)
    return found[1].to_dict() if found is not None else None
