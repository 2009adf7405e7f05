"""The time of each stage of a study run, from the Snakemake benchmark files of its jobs.

Every rule that does real work writes ``results/<study>/benchmarks/<stage>/….tsv`` (wall
seconds ``s``, ``cpu_time``, ``max_rss`` in MB). This sums them per stage — the jobs' wall
seconds added up (on N cores the stages overlap, so the sum exceeds the run's wall time), their
CPU seconds, and the largest resident memory of any job — beside the run's own wall time that
``make study`` leaves in ``results/<study>/wall_seconds.txt`` when it ran from scratch.

Usage::

    .venv/bin/python benchmarks/study_stages.py [STUDY]      # default: default

Writes ``benchmarks/study_stages.json`` and prints a table.
"""
from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "study_stages.json"


def _number(row: dict, key: str) -> float:
    """A benchmark column as a number (Snakemake writes NA where it could not measure)."""
    try:
        return float(row.get(key, "NA"))
    except ValueError:
        return 0.0


def stage_times(study_dir: Path) -> dict[str, dict]:
    """Per stage (the first folder under ``benchmarks/``, or the file's stem at its top):
    jobs, summed wall and CPU seconds, and the largest max_rss (MB)."""
    stages: dict[str, dict] = {}
    root = study_dir / "benchmarks"
    for path in sorted(root.rglob("*.tsv")):
        relative = path.relative_to(root)
        stage = relative.parts[0] if len(relative.parts) > 1 else path.stem
        with path.open() as f:
            rows = list(csv.DictReader(f, delimiter="\t"))
        if not rows:
            continue
        row = rows[-1]
        entry = stages.setdefault(stage, {"jobs": 0, "wall_seconds": 0.0, "cpu_seconds": 0.0,
                                          "max_rss_mb": 0.0})
        entry["jobs"] += 1
        entry["wall_seconds"] += _number(row, "s")
        entry["cpu_seconds"] += _number(row, "cpu_time")
        entry["max_rss_mb"] = max(entry["max_rss_mb"], _number(row, "max_rss"))
    return {k: {key: round(v, 2) if isinstance(v, float) else v for key, v in e.items()}
            for k, e in stages.items()}


def main(study: str = "default") -> dict:
    study_dir = ROOT / "results" / study
    if not (study_dir / "benchmarks").is_dir():
        raise SystemExit(f"no benchmark files under {study_dir}: run the study first")
    report = {"study": study, "stages": stage_times(study_dir)}
    wall = study_dir / "wall_seconds.txt"
    if wall.exists():
        seconds, cores = wall.read_text().split()
        report.update(wall_seconds=float(seconds), cores=int(cores))
    OUT.write_text(json.dumps(report, indent=2) + "\n")
    print(f"{'stage':<14}{'jobs':>6}{'wall s (sum)':>14}{'cpu s':>10}{'max rss MB':>12}")
    for name, e in report["stages"].items():
        print(f"{name:<14}{e['jobs']:>6}{e['wall_seconds']:>14.1f}{e['cpu_seconds']:>10.1f}"
              f"{e['max_rss_mb']:>12.0f}")
    if "wall_seconds" in report:
        print(f"whole run from scratch: {report['wall_seconds']:.0f} s on {report['cores']} cores")
    print(f"wrote {OUT}")
    return report


if __name__ == "__main__":
    main(*sys.argv[1:2])
