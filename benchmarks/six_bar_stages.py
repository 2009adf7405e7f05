"""Where a Watt II batch spends its time against a four-bar batch of equal elastic DOFs.

The batches of ``six_bar_cost.py`` (64 cases; the four-bar at 6 elements, the Watt II at 4,
36 elastic DOFs each), run in ``ROUNDS`` alternating rounds with the solver's stages timed
(the stage functions wrapped by a timer; "other" is the rest of ``simulate``); for each stage
the fastest round, and the ratio.
The table of docs/performance.md, "Six-bars against four-bars", comes from it.

Run ``.venv/bin/python benchmarks/six_bar_stages.py`` (about a minute).
"""
from __future__ import annotations

import functools
import os
import statistics
import time

import single_thread  # noqa: F401,E402  (before numpy: one BLAS thread)

import ced.response.elastic as elastic  # noqa: E402
import ced.simulation.simulate as simulate  # noqa: E402
from six_bar_cost import CASES, scenes  # noqa: E402

ROUNDS = 7
NAMES = ("four_bar_same_dofs", "watt_ii")
#: (module, function, label): the stages timed.
STAGES = (
    (simulate, "load_scene", "scene load (assembly check)"),
    (elastic, "_near_singular", "near_singular"),
    (simulate, "_rigid_outputs", "rigid motion and joint forces"),
    (elastic, "model_for", "model (matrices, layout)"),
    (elastic, "period_terms", "period terms"),
    (elastic, "monodromy", "periodic start (monodromy)"),
    (elastic, "periodic_state", "periodic start (state)"),
    (elastic, "floquet", "Floquet multipliers"),
    (elastic, "forced_resonance", "forced-resonance check"),
    (elastic, "_recover", "recovery"),
    (elastic, "_expand", "expansion to the link DOFs"),
    (elastic, "cycle_frequencies", "modal analysis"),
    (simulate, "make_batch", "batch set-up"),
    (simulate, "make_dataset", "dataset"),
)

_spent: dict[str, float] = {}


def _timed(function, label):
    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            _spent[label] = _spent.get(label, 0.0) + time.perf_counter() - start
    return wrapper


def main() -> None:
    for module, name, label in STAGES:
        setattr(module, name, _timed(getattr(module, name), label))
    batches = {name: scenes(*CASES[name]) for name in NAMES}
    for batch in batches.values():
        simulate.simulate(batch[:1])  # warm-up
    rounds = {name: [] for name in NAMES}
    for _ in range(ROUNDS):
        for name, batch in batches.items():
            _spent.clear()
            start = time.perf_counter()
            simulate.simulate(batch)
            total = time.perf_counter() - start
            rounds[name].append({**_spent, "other": total - sum(_spent.values()),
                                 "total": total})
    print(f"{'stage (s per 64 cases)':32s} {NAMES[0]:>20s} {NAMES[1]:>10s}  ratio")
    for label in [label for *_, label in STAGES] + ["other", "total"]:
        a, b = (min(r.get(label, 0.0) for r in rounds[name]) for name in NAMES)
        ratio = f"{b / a:6.2f}" if a > 0 else "     -"
        print(f"{label:32s} {a:20.3f} {b:10.3f} {ratio}")
    totals = [b["total"] / a["total"] for a, b in zip(*(rounds[name] for name in NAMES))]
    print("total ratio, median of rounds", round(statistics.median(totals), 3),
          "by round", [round(x, 3) for x in totals])
    print("load average", [round(x, 2) for x in os.getloadavg()])


if __name__ == "__main__":
    main()
