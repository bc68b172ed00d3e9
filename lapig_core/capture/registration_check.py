"""Registration error against exact geometry, in native projector pixels."""
from __future__ import annotations

import numpy as np


def registration_error_px(decoded_xy, decoded_valid, grid_x, grid_y, exact_xy) -> np.ndarray:
    """Error of the decoded projector->camera map at integer projector grid points.

    decoded_xy (Hp, Wp, 2) camera coordinates from structured light; exact_xy (gh, gw, 2) camera
    coordinates of the same projector pixels from ray casting (NaN where not seen), at the
    integer pixel columns grid_x (gw,) and rows grid_y (gh,), evenly spaced. The camera-space
    difference is mapped back to projector pixels through the local Jacobian of the exact map.
    """
    grid_x, grid_y = np.asarray(grid_x), np.asarray(grid_y)
    step_x, step_y = float(grid_x[1] - grid_x[0]), float(grid_y[1] - grid_y[0])
    dec = decoded_xy[np.ix_(grid_y, grid_x)]
    ok = decoded_valid[np.ix_(grid_y, grid_x)] & np.isfinite(exact_xy).all(-1)
    # central differences of the exact map: d(camera)/d(projector)
    jx = np.full_like(exact_xy, np.nan)
    jy = np.full_like(exact_xy, np.nan)
    jx[:, 1:-1] = (exact_xy[:, 2:] - exact_xy[:, :-2]) / (2 * step_x)
    jy[1:-1] = (exact_xy[2:] - exact_xy[:-2]) / (2 * step_y)
    jac = np.stack([jx, jy], axis=-1)  # (..., 2 camera, 2 projector)
    ok &= np.isfinite(jac).all(axis=(-1, -2))
    diff = (dec - exact_xy)[ok]
    jac = jac[ok]
    det = np.linalg.det(jac)
    good = np.abs(det) > 1e-9
    proj_err = np.linalg.solve(jac[good], diff[good][..., None])[..., 0]
    return np.linalg.norm(proj_err, axis=-1)


def summarize_errors(errors) -> dict:
    errors = np.asarray(errors, float)
    if errors.size == 0:
        return {"registration_error_px_median": float("nan"), "registration_error_px_p95": float("nan"),
                "registration_points": 0}
    return {"registration_error_px_median": float(np.median(errors)),
            "registration_error_px_p95": float(np.percentile(errors, 95)),
            "registration_points": int(errors.size)}
