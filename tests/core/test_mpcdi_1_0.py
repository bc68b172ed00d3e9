"""MPCDI 1.0 packages (issue 52): a one- and a two-projector scene in the '2d' and 'sl' profiles, checked by a
validator written from the 1.0 text (tests/mpcdi_1_0_rules.py), not by the writer; 2.0 packages fail it."""
import datetime as dt
import os
import subprocess
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


REFERENCE = os.environ.get("LAPIG_MPCDI_REFERENCE_CHECK")


@pytest.mark.skipif(not REFERENCE, reason="LAPIG_MPCDI_REFERENCE_CHECK does not name the VESA reference reader's "
                                          "check (tools/mpcdi/reference_check.cpp says how to build it)")
@pytest.mark.parametrize("profile", ["2d", "sl"])
@pytest.mark.parametrize("projectors", [1, 2])
def test_the_vesa_reference_reader_reads_1_0_and_refuses_2_0(tmp_path, profile, projectors):
    buffers = (_buffers_2d() if profile == "2d" else _buffers_sl())[:projectors]
    extra = {"origin_of_3d_data": "floorCenter"} if profile == "sl" else {}
    old = write_mpcdi(tmp_path / "old.mpcdi", profile, buffers, date=DATE, version="1.0", **extra)
    done = subprocess.run([REFERENCE, str(old)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stdout
    lines = done.stdout.splitlines()
    assert lines[0] == f"level 4 profile {0 if profile == '2d' else 3}"  # beta maps (and distortion for sl)
    regions = [ln for ln in lines if ln.startswith("region ")]
    assert len(regions) == projectors and all("alpha 64x48" in ln and "beta yes" in ln for ln in regions)
    assert regions[0].startswith("region left 64x48 warp " + ("64x48 first 0.005 0.989583" if profile == "2d"
                                                              else "16x12 first nan nan"))
    new = write_mpcdi(tmp_path / "new.mpcdi", profile, buffers, date=DATE, **extra)
    refused = subprocess.run([REFERENCE, str(new)], capture_output=True, text=True, timeout=60)
    assert refused.returncode == 1 and "2.0 is not supported" in refused.stdout
