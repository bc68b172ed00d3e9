"""The developer commands of a source checkout parse, and every benchmark name leads to a module with run()
(a moved or doubled name once broke `bench ui`, and two helpers once added the same option)."""
import importlib
import importlib.util

import pytest

pytest.importorskip("bpy")  # dev_commands registers the add-on


def test_every_benchmark_name_has_a_module_with_run():
    if importlib.util.find_spec("torch") is None:
        pytest.skip("the benchmarks import torch")
    dev = importlib.import_module("lapig.tools.dev_commands")
    for name, module in dev.BENCHMARKS.items():
        spec = importlib.util.find_spec(f"lapig.tools.bench.bench_{module}")
        assert spec is not None, f"bench {name}: tools/bench/bench_{module}.py is missing"
        assert "def run(args)" in open(spec.origin).read(), f"bench {name}: no run(args)"


def test_the_command_line_with_the_developer_commands_parses(capsys):
    cli = importlib.import_module("lapig.lapig_addon.cli.main")
    parser = cli._parser()  # argparse refuses two options of the same name here
    with pytest.raises(SystemExit):
        parser.parse_args(["bench", "--help"])
    text = capsys.readouterr().out
    dev = importlib.import_module("lapig.tools.dev_commands")
    assert all(name in text for name in dev.BENCHMARKS)
    args = parser.parse_args(["build", "--platform", "linux-x64", "--python", "py311"])
    assert args.platform == ["linux-x64"] and args.python == "py311"


def test_pretraining_mixes_both_transports_and_never_sees_a_benchmark_texture():
    syn = importlib.import_module("lapig.tools.synthetic_setups")
    modes = {s.transport for s in syn.PRETRAIN_SETUPS}
    assert modes == {"FAST", "REALISTIC"}  # issue 16: the weights learn realistic transport too
    held_out = syn.BENCH_SETUPS + syn.REALISTIC_SETUPS
    seen = {(s.surface, s.seed) for s in syn.PRETRAIN_SETUPS}
    assert not seen & {(s.surface, s.seed) for s in held_out}
    assert "sakura" not in {s.surface for s in syn.PRETRAIN_SETUPS}
    assert len(syn.ALL_SETUPS) == len(syn.PRETRAIN_SETUPS) + len(held_out)  # no name used twice


def test_bench_weights_option_reaches_the_parser():
    cli = importlib.import_module("lapig.lapig_addon.cli.main")
    args = cli._parser().parse_args(["bench", "transport", "--parts", "headroom", "--weights", "w"])
    assert args.weights == "w" and args.parts == "headroom"


def test_finetune_length_variants_are_the_recipes_a_gpu_makes_affordable():
    pytest.importorskip("torch")
    from lapig.tools.bench import bench_finetune_length as ftl
    from lapig.lapig_core.photometric.training import PAPER_RECIPES

    paper, pairs = ftl.recipe_of("paper_whole")
    assert paper == PAPER_RECIPES["CompenNeSt"] and paper.crop is None and pairs == 8
    app_whole, pairs = ftl.recipe_of("app_whole")
    app, _ = ftl.recipe_of(1000)
    assert app_whole.crop is None and app.crop == 64 and pairs is None
    assert app_whole.needs_camera_loss and app_whole.iterations == app.iterations == 1000
    with pytest.raises(ValueError, match="unknown bogus"):
        ftl._variants(type("Args", (), {"variants": "app_whole,bogus"})())
