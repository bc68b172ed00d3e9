"""A show exported as a PNG image sequence (issue 38): names, bit depth, sidecar, replace, cancel, bad input.
No PyAV needed."""
import json
import shutil
import threading
from fractions import Fraction

import numpy as np
import pytest

from lapig.lapig_core.common.imageio import decode_image, to_bit_depth
from lapig.lapig_core.export import show_output
from lapig.lapig_core.export.image_sequence import write_image_sequence
from lapig.lapig_core.export.projector_image import ExportError
from lapig.lapig_core.export.show_output import Cancelled, frame_rate

W, H = 64, 48


def _frames(n=4):
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    return [np.stack([xx / W, yy / H, np.full_like(xx, i / max(1, n - 1))], -1) for i in range(n)]


def _read(path):
    return decode_image(np.fromfile(path, np.uint8))


@pytest.mark.parametrize("depth", [8, 16])
def test_frames_named_in_order_at_their_bit_depth(tmp_path, depth):
    frames = _frames(3)
    out = write_image_sequence(frames, tmp_path / "seq", 29.97, depth, show={"looks": ["a"]})
    names = sorted(p.name for p in (tmp_path / "seq").iterdir())
    assert names == ["frame_000001.png", "frame_000002.png", "frame_000003.png", "sequence.json"]
    for path, src in zip(out["files"], frames):
        img = _read(path)
        assert img.dtype == (np.uint8 if depth == 8 else np.uint16) and img.shape == (H, W, 3)
        assert np.array_equal(img, to_bit_depth(src, depth))
    side = json.loads(out["sidecar"].read_text())
    s = side["sequence"]
    assert (s["frame_count"], s["width"], s["height"], s["bit_depth"], s["fps_rational"]) == (3, W, H, depth,
                                                                                             "30000/1001")
    assert s["duration_s"] == pytest.approx(3 * 1001 / 30000) and side["show"] == {"looks": ["a"]}
    assert [p.name for p in tmp_path.iterdir()] == ["seq"]  # no scratch folder left


def test_a_new_sequence_replaces_a_previous_one_whole(tmp_path):
    write_image_sequence(_frames(5), tmp_path / "seq", 30)
    out = write_image_sequence(_frames(2), tmp_path / "seq", 25)
    assert sorted(p.name for p in (tmp_path / "seq").iterdir()) == ["frame_000001.png", "frame_000002.png",
                                                                    "sequence.json"]
    assert json.loads(out["sidecar"].read_text())["sequence"]["fps"] == 25
    assert [p.name for p in tmp_path.iterdir()] == ["seq"]


def test_cancel_keeps_the_previous_sequence_and_leaves_no_scratch(tmp_path):
    write_image_sequence(_frames(2), tmp_path / "seq", 30)
    before = {p.name: p.read_bytes() for p in (tmp_path / "seq").iterdir()}
    event = threading.Event()

    def frames():
        for i, f in enumerate(_frames(6)):
            if i == 3:
                event.set()
            yield f

    with pytest.raises(Cancelled):
        write_image_sequence(frames(), tmp_path / "seq", 30, cancel_event=event)
    assert {p.name: p.read_bytes() for p in (tmp_path / "seq").iterdir()} == before
    assert [p.name for p in tmp_path.iterdir()] == ["seq"]


def test_a_folder_of_other_files_is_refused_not_emptied(tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "thesis.txt").write_text("keep me")
    with pytest.raises(ExportError, match="holds other files than an image sequence"):
        write_image_sequence(_frames(1), tmp_path / "mine", 30)
    assert (tmp_path / "mine" / "thesis.txt").read_text() == "keep me"


def test_bad_input_is_one_line_before_writing(tmp_path, monkeypatch):
    with pytest.raises(ExportError, match="frame rate must be above 0"):
        write_image_sequence(_frames(1), tmp_path / "seq", 0)
    with pytest.raises(ExportError, match="bit depth must be 8 or 16"):
        write_image_sequence(_frames(1), tmp_path / "seq", 30, 10)
    with pytest.raises(ExportError, match="output folder does not exist"):
        write_image_sequence(_frames(1), tmp_path / "no" / "seq", 30)
    real = shutil.disk_usage
    monkeypatch.setattr(shutil, "disk_usage", lambda p: real(p)._replace(free=100 * 2**20))
    with pytest.raises(ExportError, match=r"needs up to 5.9 GB \(1000 frames of 1920x1080 8-bit PNG\) but .* "
                                          r"has 100.0 MB free"):
        write_image_sequence(iter([np.zeros((1080, 1920, 3), np.uint8)]), tmp_path / "seq", 30, frame_count=1000)
    assert list(tmp_path.iterdir()) == []


def test_a_frame_of_another_size_fails_and_removes_the_scratch(tmp_path):
    frames = _frames(2) + [np.zeros((H, W + 1, 3), np.float32)]
    with pytest.raises(ExportError, match="frame 3 is 65x48, the export is 64x48"):
        write_image_sequence(frames, tmp_path / "seq", 30)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("fps,expected", [(30, Fraction(30)), (29.97, Fraction(30000, 1001)), (25, Fraction(25)),
                                          (24, Fraction(24)), (60, Fraction(60)), (23.976, Fraction(24000, 1001)),
                                          (59.94, Fraction(60000, 1001)), ("30000/1001", Fraction(30000, 1001)),
                                          (12.5, Fraction(25, 2))])
def test_frame_rates_are_exact_fractions(fps, expected):
    assert frame_rate(fps) == expected


def test_the_disk_check_passes_where_there_is_room(tmp_path):
    assert show_output.check_disk_space(tmp_path, 10, 1000, "tiny") == 10000


def test_no_export_module_imports_av_at_import_time():
    """The torch-free Blender tier imports the export package without PyAV: `av` only inside functions."""
    import ast
    import pathlib

    import lapig.lapig_core.export as export

    for path in sorted(pathlib.Path(export.__file__).parent.glob("*.py")):
        for node in ast.parse(path.read_text()).body:  # module-level statements only
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            assert not any(n == "av" or n.startswith("av.") for n in names), f"{path.name} imports av at import"


def test_without_pyav_video_says_what_to_install_and_sequences_still_work(tmp_path, monkeypatch):
    import sys

    from lapig.lapig_core.export import codecs
    from lapig.lapig_core.export.video import write_video

    monkeypatch.setitem(sys.modules, "av", None)  # import av raises ModuleNotFoundError
    table = codecs.availability()
    assert set(table) == set(codecs.NAMES)
    line = table["h264"]
    assert line.startswith("H.264: video export needs PyAV: install it with 'pip install av==18.0.0'")
    assert "\n" not in line and table["hap"].startswith("HAP: video export needs PyAV")
    with pytest.raises(codecs.VideoExportError, match="video export needs PyAV"):
        write_video(_frames(2), tmp_path / "show.mp4", 30, (W, H), "h264")
    out = write_image_sequence(_frames(2), tmp_path / "seq", 30)
    assert out["frames"] == 2 and list(tmp_path.iterdir()) == [tmp_path / "seq"]
