# SPDX-License-Identifier: GPL-3.0-or-later
"""Values to JSON types for the files the add-on writes: numpy scalars and arrays, paths.

Two strengths, one module: `json_default` is json.dumps' default= for setup.json (strict: anything
else is an error) and result.json (`json_default_or_str`: a record for people never fails on a
label); `jsonable` converts a whole export sidecar beforehand (NaN and infinity to null, long arrays
summarised, dataclasses and objects with to_dict() spelled out).
"""
from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import math
import os
import warnings

import numpy as np

# Arrays in a sidecar longer than this are summarised rather than listed: a sidecar describes an
# image, it is not meant to carry one.
MAX_LISTED_ARRAY = 4096


def json_default(value):
    """json.dumps(default=...): numpy scalars and arrays, paths; TypeError for anything else."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def json_default_or_str(value):
    """json_default, and the str() of anything else."""
    try:
        return json_default(value)
    except TypeError:
        return str(value)


def jsonable(obj):
    """Metadata -> plain JSON types: numpy scalars/arrays converted, NaN/inf -> null."""
    if obj is None or isinstance(obj, (str, bool)):
        return obj
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, (complex, np.complexfloating)):
        return [jsonable(obj.real), jsonable(obj.imag)]
    if isinstance(obj, np.ndarray):
        if obj.size > MAX_LISTED_ARRAY:
            summary = {"shape": list(obj.shape), "dtype": str(obj.dtype)}
            if np.issubdtype(obj.dtype, np.number) and not np.issubdtype(obj.dtype, np.complexfloating):
                with np.errstate(all="ignore"), _warnings_off():
                    summary.update(min=jsonable(np.nanmin(obj)), max=jsonable(np.nanmax(obj)),
                                   mean=jsonable(np.nanmean(obj)))
            return summary
        return jsonable(obj.tolist())
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set, frozenset)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, (_dt.datetime, _dt.date)):
        return obj.isoformat()
    if isinstance(obj, bytes):
        return obj.decode("utf-8", "replace")
    if hasattr(obj, "to_dict") and callable(obj.to_dict):  # ProjectorModel and friends
        return jsonable(obj.to_dict())
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return jsonable(dataclasses.asdict(obj))
    if isinstance(obj, np.generic):
        return jsonable(obj.item())
    return str(obj)  # a sidecar is a record for people: never fail an export over a label


@contextlib.contextmanager
def _warnings_off():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices
        yield
