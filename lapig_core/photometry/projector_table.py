"""The rig as a projector table CSV, the planning form Mapping Matter / SimProj export and disguise
reads (one row a projector).

The exact column layout of that form could not be confirmed in this project's sources (no stored copy
of Mapping Matter's, SimProj's or disguise's documentation was found), so these columns are assumed,
named in words with their units, in the order the trade's tables list them: name, maker and model,
native resolution, lumens, throw ratio, lens shift (percent of the image width / height), position
(metres, Blender's world: Z up) and orientation (Euler XYZ degrees, Blender's convention: the lens looks
down its local -Z), the distance to the target and the target's illuminance (lux, mean of a white frame).
"""
from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

from ..common.atomic import commit

COLUMNS = ("Name", "Manufacturer", "Model", "Resolution X", "Resolution Y", "Lumens", "Throw Ratio",
           "Lens Shift X (%)", "Lens Shift Y (%)", "Position X (m)", "Position Y (m)", "Position Z (m)",
           "Rotation X (deg)", "Rotation Y (deg)", "Rotation Z (deg)", "Target Distance (m)",
           "Target Illuminance (lux)")


@dataclass(frozen=True)
class ProjectorRow:
    name: str
    maker: str
    model: str
    resolution: tuple[int, int]
    lumens: float
    throw_ratio: float
    shift_x: float  # image widths
    shift_y: float  # image heights
    position_m: tuple[float, float, float]
    rotation_deg: tuple[float, float, float]
    target_distance_m: float
    target_lux: float

    def cells(self) -> list:
        return [self.name, self.maker, self.model, self.resolution[0], self.resolution[1], round(self.lumens),
                round(self.throw_ratio, 3), round(100 * self.shift_x, 1), round(100 * self.shift_y, 1),
                *(round(v, 4) for v in self.position_m), *(round(v, 3) for v in self.rotation_deg),
                round(self.target_distance_m, 3), round(self.target_lux, 1)]


def table_text(rows: list[ProjectorRow]) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(COLUMNS)
    for row in rows:
        writer.writerow(row.cells())
    return out.getvalue()


def write_projector_table(path, rows: list[ProjectorRow]) -> Path:
    """Write the table whole or not at all (temp then rename)."""
    path = Path(path)
    commit([(path, table_text(rows).encode("utf-8"))])
    return path
