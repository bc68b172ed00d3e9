"""What a refinement adds to its result's summary (the line's figures, the record, the metrics), for one
projector's refinement (refine_job) and several's (refine_joint) alike."""
from __future__ import annotations


def refine_line(record: dict) -> str:
    """'; refined 33.1 -> 39.8 dB (floor 41.2), 3 steps, 12 s' for the panel's result line."""
    if not record or record.get("refined_psnr") is None:
        return ""
    return (f"; refined {record['open_loop_psnr']:.1f} -> {record['refined_psnr']:.1f} dB "
            f"(floor {record['noise_floor_psnr']:.1f}), {record['iterations']} steps, {record['seconds']:.0f} s")


def with_refine(line: str, refined: str) -> str:
    """The result line with this refinement's figures in place of an earlier one's, before ' | ' (the panel
    shows what follows it on a line of its own)."""
    head, bar, missed = line.partition(" | ")
    return head.split("; refined")[0] + refined + (bar + missed if bar else "")


def record_refinement(summary: dict, record: dict) -> None:
    """The refinement's record, its figures on the result's line and in its metrics (result.json)."""
    summary["refine"] = record
    summary["summary_line"] = with_refine(summary.get("summary_line") or summary.get("prompt") or "result",
                                          refine_line(record))
    summary.setdefault("metrics", {}).update(
        {"refine_open_loop_psnr": record["open_loop_psnr"], "refine_refined_psnr": record["refined_psnr"],
         "refine_noise_floor_psnr": record["noise_floor_psnr"], "refine_iterations": record["iterations"],
         "refine_seconds": record["seconds"]})
