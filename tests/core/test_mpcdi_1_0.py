"""MPCDI 1.0 packages (issue 52): a one- and a two-projector scene in the '2d' and 'sl' profiles, checked by a
validator written from the 1.0 text (tests/mpcdi_1_0_rules.py), not by the writer; 2.0 packages fail it."""
import datetime as dt
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

from lapig.lapig_core.export.mpcdi import MpcdiBuffer, write_mpcdi
from mpcdi_1_0_rules import pfm_floats, problems
from test_mpcdi import _buffers_2d, _buffers_sl, _region_2d, _warp_2d  # noqa: F401 (the 2.0 tests' scenes)

DATE = dt.datetime(2026, 12, 6, 23, 40, 0)


def _root(path):
    with zipfile.ZipFile(path) as archive:
        return ET.fromstring(archive.read("mpcdi.xml"))


@pytest.mark.parametrize("projectors", [1, 2])
@pytest.mark.parametrize("beta,level", [(False, 3), (True, 4)])
def test_2d_packages_follow_the_1_0_rules(tmp_path, projectors, beta, level):
    buffers = _buffers_2d(with_beta=beta)[:projectors]
    path = write_mpcdi(tmp_path / "wall.mpcdi", "2d", buffers, date=DATE, version="1.0")
    assert problems(path) == []
    root = _root(path)
    assert root.attrib == {"profile": "2d", "level": str(level), "date": "2026-12-06 23:40:00", "version": "1.0"}
    assert len(root.findall("display/buffer")) == projectors == len(root.findall("files/fileset"))


def test_a_coarse_2d_warp_is_level_1_and_a_finer_one_level_3(tmp_path):
    coarse = [MpcdiBuffer("p", (64, 48), [_region_2d("left", grid=(24, 32), with_beta=False)])]
    path = write_mpcdi(tmp_path / "coarse.mpcdi", "2d", coarse, date=DATE, version="1.0")
    assert problems(path) == [] and _root(path).get("level") == "1"
    with zipfile.ZipFile(path) as archive:
        warp = archive.read("left_warp.pfm")
    assert warp.startswith(b"PF\n32 24\n-1.000000\n") and len(pfm_floats(warp, 3)) == 3


@pytest.mark.parametrize("projectors", [1, 2])
@pytest.mark.parametrize("distortion,level", [(False, 2), (True, 4)])
def test_sl_packages_follow_the_1_0_rules(tmp_path, projectors, distortion, level):
    buffers = _buffers_sl(distortion=distortion)[:projectors]
    path = write_mpcdi(tmp_path / "lamps.mpcdi", "sl", buffers, origin_of_3d_data="floorCenter", date=DATE,
                       version="1.0")
    assert problems(path) == []
    assert _root(path).get("level") == str(level)  # the beta maps: 2, with distortion maps 4


def test_the_validator_refuses_a_2_0_package_and_16_bit_maps(tmp_path):
    path = write_mpcdi(tmp_path / "two.mpcdi", "2d", _buffers_2d(), date=DATE)
    found = problems(path)
    assert any("version is '2.0'" in p for p in found) and any("not in 1.0" in p for p in found)
    deep = write_mpcdi(tmp_path / "deep.mpcdi", "2d", _buffers_2d(), date=DATE, version="1.0", bit_depth=16)
    assert any("8-bit maps only" in p for p in problems(deep))


def test_an_unknown_version_is_one_line(tmp_path):
    with pytest.raises(ValueError, match=r"^MPCDI version must be one of 2.0, 1.0, got '1.1'$"):
        write_mpcdi(tmp_path / "x.mpcdi", "2d", _buffers_2d(), version="1.1")
    assert list(tmp_path.iterdir()) == []
