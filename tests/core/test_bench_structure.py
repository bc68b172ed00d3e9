"""bench structure counts what issue 51 checks, from git: the product's lines and the branches on a projector count."""
from lapig.tools.bench import bench_structure as bs


def test_product_lines_count_every_tracked_product_file():
    files = bs._product_files()
    assert any(f.startswith("lapig_core/") for f in files) and any(f.startswith("panels/") for f in files)
    assert not [f for f in files if f.startswith(("tools/", "tests/"))]
    assert bs.product_lines() == sum(len((bs.ROOT / f).read_text(encoding="utf-8").splitlines()) for f in files)


def test_projector_count_branches_are_found_and_only_they():
    assert bs.COUNT_BRANCH.search("    return JOINT if projector_count > 1 else PROJECTOR_SPACE")
    assert bs.COUNT_BRANCH.search("if len(rig.projectors) == 1:")
    assert not bs.COUNT_BRANCH.search("projector_count > 12")
    assert not bs.COUNT_BRANCH.search("for k in range(projector_count):")


def test_the_house_keeps_issue_51s_checks():
    figures = bs.run(None)
    assert figures["services_named_multi_or_several"] == [] and figures["joint_refine_twin"] is False
    assert len(figures["projector_count_branches"]) <= 3
    assert figures["readme_lines"] <= 200 and figures["docs_pages"] >= 6
    assert figures["benchmarks_table_first_line"] is not None and figures["benchmarks_table_first_line"] <= 80
