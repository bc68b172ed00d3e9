# SPDX-License-Identifier: GPL-3.0-or-later
"""The working frame: the projector's aspect at the networks' sizes."""
import pytest
torch = pytest.importorskip("torch")  # the torch-free tier of older and newer Blenders skips this

from lapig.lapig_core.optics.working_frame import WorkingFrameError, check_aspect, working_frame
from lapig.lapig_core.photometric import archs


@pytest.mark.parametrize("long_side, projector, frame", [
    (320, (800, 600), (320, 240)), (256, (800, 600), (256, 192)), (320, (1920, 1080), (320, 180)),
    (256, (1920, 1080), (256, 144)), (256, (600, 800), (192, 256)), (256, (256, 256), (256, 256)),
    (250, (800, 600), (252, 188)), (64, (64, 36), (64, 36)), (100, (3840, 2160), (100, 56)),
])
def test_the_long_side_gets_the_working_size_and_both_sides_a_multiple_of_4(long_side, projector, frame):
    assert working_frame(long_side, *projector) == frame
    assert all(side % 4 == 0 for side in frame)
    check_aspect(frame, projector)  # rounding stays within the tolerance


@pytest.mark.parametrize("frame", [(64, 48), (64, 36), (28, 48)])
def test_every_network_returns_a_working_frame_at_its_own_size(frame):
    w, h = frame
    x, s = torch.rand(1, 3, h, w), torch.rand(1, 3, h, w)
    for arch in ("CompenNeSt", "PCNet"):
        with torch.no_grad():
            assert archs.build(arch)(x, s).shape == (1, 3, h, w)


@pytest.mark.parametrize("long_side, projector, match", [
    (8, (800, 600), "16 to 1024"), (2048, (3840, 2160), "16 to 1024"), (900, (800, 600), "larger than"),
    (32, (4000, 400), "short side needs at least 16"),
])
def test_a_working_size_the_networks_cannot_use_is_refused(long_side, projector, match):
    with pytest.raises(WorkingFrameError, match=match):
        working_frame(long_side, *projector)


def test_a_frame_of_another_aspect_is_refused_with_both_sizes():
    with pytest.raises(WorkingFrameError, match=r"256x256 \(aspect 1.000\) but the projector is 1920x1080") as err:
        check_aspect((256, 256), (1920, 1080), "the data set", advice="capture with this projector")
    assert str(err.value).endswith("capture with this projector")
