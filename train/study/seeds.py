"""A study run once per training seed: Tables 1 and 2 as mean, spread and per-seed values, and whether
each of the paper's orderings holds beyond the spread.

An ordering A > B holds *beyond the spread* when A's worst seed is still above B's best (their
ranges over the seeds do not overlap); otherwise the tables say in how many seeds it holds.
"""

from __future__ import annotations

import statistics
from collections.abc import Sequence
from pathlib import Path

from simgen.atomic import atomic_path
from train.evaluation.ap_table import mean_ap
from train.study.report import LABELS, PAPER_TABLE1, PAPER_TABLE2
from train.study.run import StudyResult

# The paper's orderings: Table 1 (3D AP of the boxes at t) and Table 2 (sAMOTA at IoU 0.25, filtered tracklets).
TABLE1_ORDER = ("late", "early", "single")
TABLE2_ORDER = (("3D DIoU", "AB3DMOT"), ("3D DIoU + birth/death + split", "3D DIoU"))
TRACKING_IOU = 0.25


def mean_sd(values: Sequence[float]) -> tuple[float, float]:
    """Mean and sample standard deviation of per-seed values (sd 0 for one seed)."""
    return statistics.mean(values), statistics.stdev(values) if len(values) > 1 else 0.0


def _spread(values: Sequence[float]) -> str:
    """`mean ± sd (min-max)` of per-seed values."""
    mean, sd = mean_sd(values)
    return f"{mean:.2f} ± {sd:.2f} ({min(values):.2f}-{max(values):.2f})"


def _ordering(name_a: str, a: Sequence[float], name_b: str, b: Sequence[float]) -> str:
    holds = sum(x > y for x, y in zip(a, b))
    beyond = min(a) > max(b)
    verdict = "**beyond the spread**" if beyond else ("within the spread" if holds else "**reversed in every seed**")
    means = f"{statistics.mean(a):.2f} and {statistics.mean(b):.2f}"
    return f"- {name_a} > {name_b}: holds in {holds} of {len(a)} seeds, {verdict} (means {means})."


def table1_seeds(results: Sequence[StudyResult], seeds: Sequence[int], command: str) -> str:
    """Table 1 over seeds: 3D and BEV AP R40 (all boxes at t) per model."""
    density = results[0].dataset.scenario.scan.density
    models = [r.model for r in results[0].detectors]
    ap = {(m, kind): [mean_ap(next(d for d in r.detectors if d.model == m).rows, kind) for r in results]
          for m in models for kind in ("3d", "bev")}
    lines = [f"# Table 1 on `{results[0].dataset.scenario.name}` over training seeds {', '.join(map(str, seeds))}", "",
             f"Command: `{command}`", "",
             "AP R40 in percent, IoU 0.5, all val boxes at t; each seed's own tables are in `seed_<seed>/`. "
             "mean ± sd (min-max) over the seeds, then each seed's value.", "",
             "| Method | 3D | BEV | 3D per seed | BEV per seed | paper 3D |", "| --- |" + " ---: |" * 5]
    for m in models:
        paper = PAPER_TABLE1.get((m, density), (None, None))[1]
        lines.append(
            f"| {LABELS[m]} (x{density:g}) | {_spread(ap[(m, '3d')])} | {_spread(ap[(m, 'bev')])} | "
            + " / ".join(f"{v:.2f}" for v in ap[(m, "3d")])
            + " | "
            + " / ".join(f"{v:.2f}" for v in ap[(m, "bev")])
            + f" | {'–' if paper is None else f'{paper:.2f}'} |"
        )
    order = [m for m in TABLE1_ORDER if m in models]
    lines += ["", "The paper's order (3D AP):", ""]
    lines += [_ordering(LABELS[a], ap[(a, "3d")], LABELS[b], ap[(b, "3d")]) for a, b in zip(order, order[1:])]
    return "\n".join(lines) + "\n"


def table2_seeds(results: Sequence[StudyResult], seeds: Sequence[int], command: str) -> str:
    """Table 2 over seeds: sAMOTA at IoU 0.25 on the filtered tracklets, per tracker."""
    name = results[0].dataset.scenario.name
    lines = [f"# Table 2 on `{name}` over training seeds {', '.join(map(str, seeds))}", "", f"Command: `{command}`", ""]
    if any(not r.filters for r in results):
        return "\n".join(lines + ["Not run: the frame split has no contiguous val sequence to track."]) + "\n"
    trackers = [t.tracker for t in results[0].trackers if t.filtered and t.min_iou == TRACKING_IOU]
    samota = {
        t: [
            100
            * next(x for x in r.trackers if x.tracker == t and x.filtered and x.min_iou == TRACKING_IOU).metrics.samota
            for r in results
        ]
        for t in trackers
    }
    lines += ["sAMOTA in percent, 3D IoU >= 0.25, tracklets filtered by each tracker's own rule (chosen on each "
              "seed's train clips); each seed's own tables are in `seed_<seed>/`.", "",
              "| Method | sAMOTA | per seed | paper |", "| --- | ---: | ---: | ---: |"]
    for t in trackers:
        paper = PAPER_TABLE2.get(t, (None,))[0]
        lines.append(f"| {t} | {_spread(samota[t])} | " + " / ".join(f"{v:.2f}" for v in samota[t])
                     + f" | {'–' if paper is None else f'{paper:.2f}'} |")
    lines += ["", "The paper's orderings (sAMOTA):", ""]
    lines += [_ordering(a, samota[a], b, samota[b]) for a, b in TABLE2_ORDER if a in samota and b in samota]
    return "\n".join(lines) + "\n"


def write_seed_tables(results: Sequence[StudyResult], seeds: Sequence[int], command: str, out: Path) -> list[Path]:
    """OUT/table1.md and OUT/table2.md over the seeds, each written atomically."""
    texts = {"table1.md": table1_seeds(results, seeds, command), "table2.md": table2_seeds(results, seeds, command)}
    out.mkdir(parents=True, exist_ok=True)
    for file, text in texts.items():
        with atomic_path(out / file) as tmp:
            tmp.write_text(text)
    return [out / file for file in texts]
