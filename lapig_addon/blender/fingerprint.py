"""A short hash of everything a capture depends on, to tell when captures have gone stale."""
from __future__ import annotations

import hashlib
import json

import numpy as np


def _matrix(obj):
    return np.round(np.array(obj.matrix_world), 5).tolist()


def rig_fingerprint(projector, camera, target, transport: dict) -> str:
    """transport: the rig's LightTransport.state() (scene_state.rig_fingerprint reads it)."""
    p, c = projector.lapig_projector, camera.lapig_camera
    state = {
        "projector": [_matrix(projector), p.resolution_x, p.resolution_y, round(p.throw_ratio, 5),
                      round(p.shift_x, 5), round(p.shift_y, 5), round(p.brightness, 3),
                      round(p.black_level, 5), round(p.gamma, 4)],
        "camera": [_matrix(camera), c.resolution_x, c.resolution_y, round(camera.data.lens, 4),
                   round(camera.data.sensor_width, 4), round(c.response_gamma, 4)],
        "target": [_matrix(target), len(target.data.vertices), target.name],
        "transport": transport,
    }
    return hashlib.sha1(json.dumps(state, sort_keys=True).encode()).hexdigest()[:16]
