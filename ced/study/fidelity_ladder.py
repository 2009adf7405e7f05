"""The fidelity ladder: one scene through every model, each refined until converged.

Rungs (the formulations of docs/theory.md): ``rigid``, quasi-static ``euler_bernoulli`` (no elastic
inertia), dynamic ``euler_bernoulli``, ``timoshenko``, ``seed_lame`` (thesis II.5) and
``plane_stress`` (thesis II.3) where available. For each rung the mesh is doubled until the
peak stress of the watched link and its first natural frequency change by less than
``tolerance``; the table reports the converged values and the solve time per case.
"""
from __future__ import annotations

import copy
import json
import time
from pathlib import Path

import numpy as np

from ..fem import elements
from ..problem.scene import load_scene
from ..response.batch import make_batch
from ..simulation.simulate import solve_batch

__all__ = ["RUNGS", "REFERENCE_RUNG", "run_rung", "run_ladder", "write_ladder", "ladder_figure",
           "run_scene_ladder"]

#: name -> (formulation, effects to remove from the scene, element counts to try)
RUNGS = {
    "rigid": ("rigid", set(), (1,)),
    "quasi_static_euler_bernoulli": ("euler_bernoulli", {"elastic_inertia", "coriolis"},
                                     (2, 4, 8, 16, 32)),
    "euler_bernoulli": ("euler_bernoulli", set(), (2, 4, 8, 16, 32)),
    "timoshenko": ("timoshenko", set(), (2, 4, 8, 16, 32, 64)),
    "seed_lame": ("seed_lame", set(), (1, 2, 4, 8)),
    "plane_stress": ("plane_stress", set(), (4, 8, 16, 32)),
}


def _measure(scene: dict, link: str) -> dict:
    normalized = load_scene(scene)
    start = time.perf_counter()
    out = solve_batch(make_batch([normalized]))
    elapsed = time.perf_counter() - start
    names = list(normalized["links"])
    i = names.index(link)
    result = {"solve_time": elapsed,
              "peak_deflection": float(out["peak_deflection"][0, i]) if "peak_deflection" in out
              else 0.0,
              "peak_stress": float(out["peak_stress"][0, i]) if "peak_stress" in out else 0.0,
              "first_frequency": float(np.min(out["natural_frequency"][0, :, 0]))
              if "natural_frequency" in out else float("nan")}
    return result


def run_rung(scene: dict, rung: str, link: str, tolerance: float = 0.01) -> dict:
    """Converged results of one rung: refine until the peak stress and first frequency of
    ``link`` change by less than ``tolerance`` between two meshes.

    Parameters
    ----------
    scene : dict
        A normalized scene.
    rung : str
        The model (a key of :data:`RUNGS`).
    link : str
        The link whose results are compared.
    tolerance : float
        Relative change that counts as converged (dimensionless).

    Returns
    -------
    dict
        Elements, peak deflection (m), peak stress (Pa), first frequency (Hz), solve time (s)
        and whether it converged.
    """
    formulation, drop, meshes = RUNGS[rung]
    base = copy.deepcopy(scene)
    effects = base.get("effects", ["inertia", "elastic_inertia", "coriolis", "centrifugal",
                                   "axial_stiffening"])
    base["effects"] = [e for e in effects if e not in drop]
    previous, converged = None, False
    for n in meshes:
        trial = copy.deepcopy(base)
        trial["discretization"] = {**trial.get("discretization", {}),
                                   "formulation": formulation, "elements_per_link": n}
        if formulation == "seed_lame":
            trial.setdefault("time", {}).pop("integrator", None)  # its own default: Houbolt
        if formulation == "plane_stress":
            # Hundreds of DOFs per link: Craig–Bampton keeps the periodic shooting affordable.
            trial["discretization"]["modes_per_link"] = 12
        result = _measure(trial, link)
        result["elements_per_link"] = n
        if previous is not None:
            changes = [abs(result[k] / previous[k] - 1) for k in ("peak_stress",
                       "first_frequency") if previous[k] and np.isfinite(previous[k])]
            if all(c < tolerance for c in changes):
                converged = True
                break
        previous = result
        if formulation == "rigid":
            converged = True
            break
    result["converged"] = converged
    return result


def run_ladder(scene: dict, link: str = "coupler", rungs=None) -> dict[str, dict]:
    """Every available rung on ``scene``; rungs whose formulation is not available are
    reported with the reason instead of results.

    Parameters
    ----------
    scene : dict
        A normalized scene.
    link : str
        The link whose results are compared.
    rungs : sequence of str, optional
        The models (default: every rung).

    Returns
    -------
    dict of str to dict
        Rung -> :func:`run_rung` result (or the reason it is not available).
    """
    out = {}
    for rung in rungs or RUNGS:
        formulation = RUNGS[rung][0]
        if formulation != "rigid" and formulation not in elements.FORMULATIONS:
            out[rung] = {"available": False, "reason": f"{formulation} not implemented"}
            continue
        out[rung] = {"available": True, **run_rung(scene, rung, link)}
    return out


def write_ladder(results: dict[str, dict], directory: str | Path) -> None:
    """ladder.json, ladder.md (table) and ladder.png/.svg (figure) in ``directory``.

    Parameters
    ----------
    results : dict of str to dict
        :func:`run_ladder` results.
    directory : str or Path
        Target folder (created if missing).
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "ladder.json").write_text(json.dumps(results, indent=2) + "\n")
    lines = ["| model | elements | peak deflection [mm] | peak stress [MPa] | "
             "first frequency [Hz] | solve time [ms] | converged |",
             "|---|---|---|---|---|---|---|"]
    for rung, r in results.items():
        if not r["available"]:
            lines.append(f"| {rung} | — | — | — | — | — | {r['reason']} |")
            continue
        lines.append(f"| {rung} | {r['elements_per_link']} | {1e3 * r['peak_deflection']:.4g} | "
                     f"{1e-6 * r['peak_stress']:.4g} | {r['first_frequency']:.4g} | "
                     f"{1e3 * r['solve_time']:.3g} | {'yes' if r['converged'] else 'no'} |")
    (directory / "ladder.md").write_text("\n".join(lines) + "\n")

    ladder_figure(results, directory / "ladder.png")


#: The rung the others are compared with in :func:`ladder_figure`: the continuum model.
REFERENCE_RUNG = "plane_stress"


def ladder_figure(results: dict[str, dict], png: str | Path) -> None:
    """What each model predicts and what it costs, as points: left, each rung's peak stress
    and first natural frequency (linear axes, so distances mean something); right, each
    rung's difference in peak stress from :data:`REFERENCE_RUNG` against its solve time per
    case (log-log).

    Parameters
    ----------
    results : dict of str to dict
        :func:`run_ladder` results.
    png : str or Path
        The PNG file written (and an SVG beside it).
    """
    import matplotlib.pyplot as plt

    from .figures import plain_ticks, save

    done = {k: v for k, v in results.items() if v["available"] and k != "rigid"}
    names = list(done)
    reference = done.get(REFERENCE_RUNG) or done[names[-1]]
    ref_name = REFERENCE_RUNG if REFERENCE_RUNG in done else names[-1]
    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(13, 4.0), constrained_layout=True,
                                        gridspec_kw={"width_ratios": (1, 1, 1.3)})
    y = np.arange(len(names))
    for ax, key, scale, label in ((ax1, "peak_stress", 1e-6, "peak stress [MPa]"),
                                  (ax2, "first_frequency", 1.0, "first frequency [Hz]")):
        ax.plot([scale * done[n][key] for n in names], y, "o", color="C0")
        ax.axvline(scale * reference[key], color="0.5", ls="--", lw=0.8,
                   label=f"{ref_name} (reference)")
        ax.set_xlabel(label)
        ax.set_yticks(y, names if ax is ax1 else [""] * len(names))
        ax.grid(True, axis="x", lw=0.3)
        ax.set_ylim(len(names) - 0.5, -0.5)
    ax1.legend(fontsize=7, loc="lower right")
    for i, n in enumerate(names):
        if n == ref_name:
            continue
        error = abs(done[n]["peak_stress"] / reference["peak_stress"] - 1.0)
        time = 1e3 * done[n]["solve_time"]
        ax3.plot(time, 100 * max(error, 1e-4), "o", color=f"C{i}")
        # alternate above and below: rungs of equal error and similar time would overlap
        ax3.annotate(f"{n} ({100 * error:.2g} %)", (time, 100 * max(error, 1e-4)),
                     textcoords="offset points", xytext=(5, 4 if i % 2 else -10), fontsize=7)
    ax3.axvline(1e3 * reference["solve_time"], color="0.5", ls="--", lw=0.8)
    ax3.text(1e3 * reference["solve_time"], 1.0, f" {ref_name}", rotation=90, fontsize=7,
             va="top", transform=ax3.get_xaxis_transform(), color="0.4")
    ax3.set_xscale("log")
    ax3.set_yscale("log")
    plain_ticks(ax3.xaxis)
    plain_ticks(ax3.yaxis)
    ax3.set_xlabel("solve time per case [ms]")
    ax3.set_ylabel(f"peak stress difference from {ref_name} [%]")
    ax3.grid(True, which="major", lw=0.3)
    fig.suptitle("Fidelity ladder: what each model predicts and what it costs "
                 "(each refined until converged)", fontsize=10)
    save(fig, png)


def run_scene_ladder(path: str | Path, directory: str | Path, link: str = "coupler") -> None:
    """Validate the scene file, run every rung on it and write the results to ``directory``.

    Parameters
    ----------
    path : str or Path
        A scene file.
    directory : str or Path
        Target folder.
    link : str
        The link whose results are compared.
    """
    import yaml

    load_scene(path)  # a bad scene fails here, naming the key, before anything is written
    with open(path) as handle:
        scene = yaml.safe_load(handle)
    write_ladder(run_ladder(scene, link=link), directory)
