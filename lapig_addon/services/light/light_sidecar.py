"""What Export adds from a result's light report: the sidecar's `light` figures and the projector table.

A result has a light report once `report` ran on it (light_report.json in its folder); without one,
Export writes what it always wrote."""
from __future__ import annotations

from pathlib import Path

from ....lapig_core.photometry.projector_table import ProjectorRow, write_projector_table
from .light_report import read_report

SIDECAR_KEYS = ("lumens", "light_power_w", "ambient_lux", "lamp_direction", "projector_contrast", "white_lux",
                "look_lux", "total_lux", "luminance_cd_m2", "contrast_ratio", "contrast_below_5_share", "fixes",
                "warning", "dose")


def sidecar_fields(folder, k: int = 0) -> dict:
    """Projector k's sidecar `light` from the result's light report ({} without one): the rig's figures (all its
    projectors together), and where the report names each projector (a rig of several: light_joint.joint_report)
    under `projector` its own lumens, watts and share, with the report's frame."""
    report = read_report(folder)
    if not report:
        return {}
    light = {key: report[key] for key in SIDECAR_KEYS if key in report}
    if report.get("preset"):
        light["preset"] = {key: report["preset"].get(key) for key in ("id", "name", "ansi_lumens", "contrast", "source")}
    own = report.get("projectors") or []
    if k < len(own):
        light["projector"] = own[k]
        light["frame"] = report.get("frame")
    return {"light": light}


def table_rows(report: dict | None) -> list:
    """Every projector's row of the projector table of a light report: one projector's report holds its row, a
    report of several one row each ([] without a report)."""
    report = report or {}
    rows = report.get("projector_table_rows") or [r for r in [report.get("projector_table_row")] if r]
    return [_row(row) for row in rows]


def write_table_beside(image_path, folder) -> Path | None:
    """<image stem>_projectors.csv beside the exported image(s): every projector's row, when the result has a light
    report (None without)."""
    rows = table_rows(read_report(folder))
    if not rows:
        return None
    image_path = Path(image_path)
    return write_projector_table(image_path.with_name(image_path.stem + "_projectors.csv"), rows)


def _row(row: dict) -> ProjectorRow:
    return ProjectorRow(row["name"], row.get("maker", ""), row.get("model", ""), tuple(row["resolution"]),
                        float(row["lumens"]), float(row["throw_ratio"]), float(row["shift_x"]),
                        float(row["shift_y"]), tuple(row["position_m"]), tuple(row["rotation_deg"]),
                        float(row["target_distance_m"]), float(row["target_lux"]))

