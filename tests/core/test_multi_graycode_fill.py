# SPDX-License-Identifier: GPL-3.0-or-later
"""Registration where the finest Gray-code stripes blur (multi/graycode_fill): a camera whose right part sees
8 projector columns per pixel (a surface at grazing incidence) reads the coarse bits there but not the finest."""
import numpy as np

from lapig.lapig_core.capture.structured_light import decode_graycode, decode_graycode_partial, graycode_patterns
from lapig.lapig_core.multi.graycode_fill import fill_unread_bits

PW, PH = 64, 32
SHARP = 20  # camera columns 0..19 see projector columns 0..19 one to one
WIDE = 8  # camera columns 20..24 each see 8 projector columns: 20..27, 28..35, ... 52..59


def _columns(x):
    return [x] if x < SHARP else list(range(SHARP + WIDE * (x - SHARP), SHARP + WIDE * (x - SHARP + 1)))


def _captures(dark_row=None):
    cam_w = SHARP + (PW - 4 - SHARP) // WIDE
    caps = []
    for p in graycode_patterns(PW, PH):
        p = p.astype(np.float32) / 255
        cam = np.stack([p[:, _columns(x)].mean(axis=1) for x in range(cam_w)], axis=1)
        cam = 0.05 + 0.8 * cam
        if dark_row is not None:
            cam[dark_row] = 0.05 + 0.02 * (cam[dark_row] - 0.05) / 0.8  # a faint pixel: barely lit
        caps.append(np.repeat(cam[..., None], 3, axis=-1))
    return caps


def test_where_every_bit_reads_the_allowed_position_is_the_decoded_pixel():
    caps = _captures()
    strict = decode_graycode(caps, PW, PH)
    partial = decode_graycode_partial(caps, PW, PH)
    rows, cols = np.nonzero(strict.valid)
    assert strict.valid[:, :SHARP].all()
    for axis, truth in (("x", strict.proj_x), ("y", strict.proj_y)):
        allowed = partial.positions(axis, rows, cols)
        assert (allowed.sum(axis=1) == 1).all() and (allowed.argmax(axis=1) == truth[rows, cols]).all()


def test_blurred_columns_are_lit_the_bits_that_read_hold_and_the_fill_places_them():
    caps = _captures()
    strict = decode_graycode(caps, PW, PH)
    partial = decode_graycode_partial(caps, PW, PH)
    wide = np.zeros(strict.shape, bool)
    wide[:, SHARP:] = True
    assert not strict.valid[wide].any()  # the strict decode rejects every blurred pixel
    assert partial.lit[wide].all()
    centres = np.array([np.mean(_columns(x)) for x in range(strict.shape[1])])
    truth = np.broadcast_to(centres, strict.shape)
    # every projector column the pixel sees agrees with the bits that read (they are right, only fewer)
    rows, cols = np.nonzero(wide)
    allowed = partial.positions("x", rows, cols)
    for i, (r, c) in enumerate(zip(rows, cols)):
        assert allowed[i, _columns(c)].all()
    assert (allowed.sum(axis=1) < PW / 2).all()  # and they still say a lot
    filled = fill_unread_bits(strict, partial)
    assert filled.filled[wide].all() and filled.decoded.valid.all()
    err = np.abs(filled.decoded.proj_x - truth)[wide]
    assert err.max() <= WIDE / 2  # within the pixel's own footprint
    assert (filled.decoded.proj_y[wide] == np.broadcast_to(np.arange(PH)[:, None], strict.shape)[wide]).all()
    # decoded pixels keep their values exactly
    ok = strict.valid
    assert (filled.decoded.proj_x[ok] == strict.proj_x[ok]).all() and (filled.decoded.proj_y[ok] == strict.proj_y[ok]).all()


def test_a_faint_pixel_and_a_capped_doubt_stay_unregistered():
    caps = _captures(dark_row=5)
    strict = decode_graycode(caps, PW, PH)
    partial = decode_graycode_partial(caps, PW, PH)
    assert not partial.lit[5].any()
    filled = fill_unread_bits(strict, partial)
    assert not filled.decoded.valid[5].any()
    none = fill_unread_bits(strict, partial, max_unknown_bits=-1)
    assert (none.decoded.valid == strict.valid).all() and not none.filled.any()
    tight = fill_unread_bits(strict, partial, max_unknown_bits=1)  # the blurred pixels doubt 4 or more columns
    assert not tight.filled[:, SHARP:].any()
