"""What Export adds from a result's light report: the sidecar's `light` figures and the projector table.

A result has a light report once `report` ran on it (light_report.json in its folder); without one,
Export writes what it always wrote."""
from __future__ import annotations

from pathlib import Path

from ...lapig_core.photometry.projector_table import ProjectorRow, write_projector_table
from .light_report import read_report

SIDECAR_KEYS = ("lumens", "light_power_w", "ambient_lux", "lamp_direction", "projector_contrast", "white_lux",
                "look_lux", "total_lux", "luminance_cd_m2", "contrast_ratio", "contrast_below_5_share", "fixes",
                "warning", "dose")


def sidecar_fields(folder) -> dict:
    report = read_report(folder)
    if not report:
        return {}
    light = {k: report[k] for k in SIDECAR_KEYS if k in report}
    if report.get("preset"):
        light["preset"] = {k: report["preset"].get(k) for k in ("id", "name", "ansi_lumens", "contrast", "source")}
    return {"light": light}


def table_row(report: dict) -> ProjectorRow | None:
    row = (report or {}).get("projector_table_row")
    if not row:
        return None
    return _row(row)


def several_sidecar_fields(folder, k: int) -> dict:
    """Projector k's sidecar `light` from a report of several (light_report.several_report): the rig's
    figures, all projectors together, and under `projector` its own lumens, watts and share ({} without)."""
    report = read_report(folder)
    fields = sidecar_fields(folder)
    own = (report or {}).get("projectors") or []
    if fields and k < len(own):
        fields["light"]["projector"] = own[k]
        fields["light"]["frame"] = report.get("frame")
    return fields


def write_several_table(path, folder) -> Path | None:
    """<path stem>_projectors.csv: the projector table of every projector of a report of several (None without)."""
    rows = [_row(r) for r in ((read_report(folder) or {}).get("projector_table_rows") or [])]
    if not rows:
        return None
    path = Path(path)
    return write_projector_table(path.with_name(path.stem + "_projectors.csv"), rows)


def _row(row: dict) -> ProjectorRow:
    return ProjectorRow(row["name"], row.get("maker", ""), row.get("model", ""), tuple(row["resolution"]),
                        float(row["lumens"]), float(row["throw_ratio"]), float(row["shift_x"]),
                        float(row["shift_y"]), tuple(row["position_m"]), tuple(row["rotation_deg"]),
                        float(row["target_distance_m"]), float(row["target_lux"]))


def write_table_beside(image_path, folder) -> Path | None:
    """<image>_projectors.csv beside the exported image, when the result has a light report."""
    row = table_row(read_report(folder))
    if row is None:
        return None
    image_path = Path(image_path)
    return write_projector_table(image_path.with_name(image_path.stem + "_projectors.csv"), [row])
