"""Are the default study's change-point frequencies those of the motion on the time grid?

A change-point four-bar's motion passes straight through its change point onto the other
assembly branch; every evaluation on the step grid reads that one motion, and a time off the
grid (a modal phase: 12 against 128 steps per revolution) takes the branch it has at the steps
around it (docs/accuracy.md, "The change-point branch"). This draws ``CASES`` cases of the
default study's change-point family (ids evenly spaced), solves them as the study does, and
checks each modal phase's frozen frequencies against the grid motion's: within the range of
the frequencies at the four steps around the phase, widened by ``SLACK`` of their largest (a
phase on the other configuration is off by up to 100 %). Phases on the change point itself
(singular transmission: velocities interpolated across the phases) are counted apart. It also
counts the cases whose motion changes branch every turn (the second turn's coupler angle off
the first's), which repeat only every two turns. Results go to
``benchmarks/change_point_modal_check.json``; docs/accuracy.md quotes them.

Run ``.venv/bin/python benchmarks/change_point_modal_check.py`` (about a minute).
"""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from ced.fem.eigenproblem import natural_frequencies
from ced.problem.scene import load_scene
from ced.response.batch import make_batch
from ced.response.frequencies import modal_phases
from ced.response.model import build_model, terms_at
from ced.simulation.simulate import simulate
from ced.study.cases import chunk_rows, family_sizes
from ced.study.config import load_config

ROOT = Path(__file__).resolve().parent.parent
OUT = Path(__file__).with_name("change_point_modal_check.json")
CASES = 250
SLACK = 1e-2
#: Steps of the grid motion's frequencies computed at once (memory).
BLOCK = 16


def _cases(config: dict) -> tuple[np.ndarray, list[dict]]:
    size, total = int(config["chunk_size"]), family_sizes(config)["change_point"]
    ids = np.unique(np.linspace(0, total - 1, CASES).round().astype(int))
    chunks: dict[int, list] = {}
    for case in ids:
        chunks.setdefault(case // size, chunk_rows(config, "change_point", case // size))
    return ids, [chunks[case // size][case % size]["scene"] for case in ids]


def _grid_frequencies(model, steps: int, modes: int) -> np.ndarray:
    """Frozen frequencies at the steps 0 … steps of the grid, (case, step, mode) Hz; NaN where
    the terms are not finite (a crank as long as the ground, folded onto it)."""
    batch = model.batch
    out = np.full((batch.size, steps + 1, modes), np.nan)
    for start in range(0, steps + 1, BLOCK):
        part = np.arange(start, min(start + BLOCK, steps + 1))
        terms, _ = terms_at(model, batch.step_size[:, None] * part[None, :],
                            model.effects - {"damping"}, frozenset({"elastic_mass"}))
        K, M = terms.stiffness, terms.elastic_mass
        good = np.isfinite(K).all(axis=(2, 3)) & np.isfinite(M).all(axis=(2, 3))
        block = out[:, start:start + len(part)]
        block[good] = natural_frequencies(K[good][:, None], M[good][:, None], modes)[:, 0]
    return out


def main() -> None:
    config = load_config(ROOT / "config" / "config.yaml")
    ids, scenes = _cases(config)
    frequency = simulate(scenes).natural_frequency.values  # (case, phase, mode) Hz
    model = build_model(make_batch([load_scene(s) for s in scenes]))
    batch = model.batch
    per_turn = batch.scenes[0]["time"]["steps_per_revolution"]
    on_grid = _grid_frequencies(model, per_turn + 1, frequency.shape[2])
    times = modal_phases(frequency.shape[1])[None, :] / batch.speed[:, None]
    singular = batch.rigid_motion(times).singular
    lower = np.floor(times / batch.step_size[:, None]).astype(int)
    off = np.zeros(frequency.shape[:2], bool)
    warnings.filterwarnings("ignore", "All-NaN slice", RuntimeWarning)  # a folded step's NaN
    for c, j in np.ndindex(*off.shape):
        around = on_grid[c, max(lower[c, j] - 1, 0):lower[c, j] + 3]
        slack = SLACK * np.nanmax(np.abs(around), axis=0)
        f = frequency[c, j]
        off[c, j] = np.any(np.isfinite(f) & ((f < np.nanmin(around, axis=0) - slack)
                                             | (f > np.nanmax(around, axis=0) + slack)))
    off &= ~singular
    two_turns = batch.rigid_motion(batch.step_size[:, None] * np.arange(2 * per_turn + 1)[None, :])
    coupler = two_turns.link_angle[..., two_turns.topology.link_names.index("coupler")]
    apart = np.abs(np.angle(np.exp(1j * (coupler[:, per_turn:-1] - coupler[:, :per_turn]))))
    result = {
        "cases": int(len(ids)),
        "family_cases": int(family_sizes(config)["change_point"]),
        "slack": SLACK,
        "off_the_grid_motion": int(off.any(axis=1).sum()),
        "off_the_grid_motion_ids": ids[off.any(axis=1)].tolist(),
        "with_a_phase_on_the_change_point": int(singular.any(axis=1).sum()),
        "changing_branch_every_turn": int((apart.max(axis=1) > 1e-3).sum()),
    }
    OUT.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
