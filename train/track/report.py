"""`track`'s metrics: the paper's Table 2 columns (train.study.report) for one tracker, as Markdown and CSV."""

from __future__ import annotations

import csv
import io
from pathlib import Path

from train.study.report import TABLE2_COLUMNS, table2_head, table2_row
from train.track.run import MIN_IOU, TrackResult


def metric_values(result: TrackResult) -> tuple:
    """sAMOTA, AMOTA, AMOTP, MOTA, MOTP (percent), IDS, FRAG, HOTA, centre HOTA (percent), Table 2's order."""
    m, b = result.metrics, result.metrics.best
    percent = tuple(100 * v for v in (m.samota, m.amota, m.amotp, b.mota, b.motp))
    return (*percent, b.ids, b.frag, 100 * result.hota.hota, 100 * result.centre_hota.hota)


def metrics_markdown(result: TrackResult, tracker: str, command: str) -> str:
    return "\n".join([
        f"# Tracking: {tracker}", "", f"`{command}`", "",
        f"{len(result.clips)} clip{'' if len(result.clips) == 1 else 's'}, {result.frames} frames, "
        f"{result.tracks} tracks. sAMOTA, AMOTA, AMOTP, MOTA, MOTP "
        f"in percent at 3D IoU >= {MIN_IOU:g} (AB3DMOT's evaluation); MOTA, MOTP, IDS and FRAG at the score threshold "
        "of the best MOTA; HOTA on 3D IoU, centre HOTA on pitch-plane centre distance (5 m Gaussian tolerance).", "",
        *table2_head(), table2_row(tracker, metric_values(result)), "",
        f"Per 10 minutes of play (from {result.play_s:.1f} s tracked): {per_10_min(result)}.", "",
    ])


def per_10_min(result: TrackResult) -> str:
    """`IDS a, FRAG b` per 10 minutes of the game time tracked."""
    scale = 600.0 / result.play_s if result.play_s > 0 else float("nan")
    return f"IDS {result.metrics.best.ids * scale:.1f}, FRAG {result.metrics.best.frag * scale:.1f}"


def metrics_csv(result: TrackResult, tracker: str) -> str:
    m, b = result.metrics, result.metrics.best
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["tracker", "min_iou", "samota", "amota", "amotp", "mota", "motp", "ids", "frag", "tp", "fp", "fn",
                     "n_gt", "hota", "deta", "assa", "centre_hota", "frames", "tracks", "play_s"])
    writer.writerow([tracker, MIN_IOU, *(f"{v:.4f}" for v in (m.samota, m.amota, m.amotp, b.mota, b.motp)), b.ids,
                     b.frag, b.tp, b.fp, b.fn, b.n_gt,
                     *(f"{v:.4f}" for v in (result.hota.hota, result.hota.deta, result.hota.assa,
                                            result.centre_hota.hota)), result.frames, result.tracks,
                     f"{result.play_s:.2f}"])
    return text.getvalue()


def metrics_text(result: TrackResult, tracker: str) -> str:
    """The metrics as printed: one `name value` pair each."""
    pairs = ", ".join(f"{name} {value:.2f}" if isinstance(value, float) else f"{name} {value}"
                      for name, value in zip(TABLE2_COLUMNS, metric_values(result)))
    return f"{pairs}; per 10 minutes of play {per_10_min(result)}"


def write_metrics(folder: Path, result: TrackResult, tracker: str, command: str) -> None:
    (folder / "metrics.md").write_text(metrics_markdown(result, tracker, command))
    (folder / "metrics.csv").write_text(metrics_csv(result, tracker))
