"""Convergence studies: what each step of accuracy costs in time (issue 6, docs/accuracy.md).

For a reference scene of each family, a sweep of discretizations (elements per link, steps per
revolution, integrator, formulation, modal reduction) is solved; each setting is timed per case
in a batch of identical cases and its peak stress, peak deflection and first natural frequency
are compared with a converged reference.

The reference of each formulation is Richardson-extrapolated from a fine reduced model (the
truncation error of the component-mode synthesis with static load vectors is below 1e-5):
with σ(N, S) at N elements and S steps per revolution,

    σ_ref = σ(N, S) + [σ(N, S) − σ(N/2, S)]/3 + [σ(N, S) − σ(N, S/2)]/3        (order 2)

and its uncertainty is the larger of the extrapolation's correction and its difference to
the same extrapolation one level coarser. The first frequency (mean over the cycle of the lowest
mode) converges at order 4 in space and does not depend on the step.

``discretization: auto`` is checked on the same scenes: for each tolerance the chosen setting's
true error and cost are recorded next to the cheapest sweep setting that meets it.
"""
from __future__ import annotations

import copy
import itertools
import json
from pathlib import Path

from typing import TYPE_CHECKING

import numpy as np

from ..problem.errors import SceneError
from ..problem.status import STATUS_DTYPE
from ..problem.yaml_files import load_yaml

if TYPE_CHECKING:  # pandas, xarray and the solver load lazily: the Snakefile imports this module
    import pandas as pd
    import xarray as xr

__all__ = ["load_sweep", "settings", "run_family", "accuracy_table", "auto_table",
           "estimate_validation", "TARGETS"]

#: A true error counts only above this multiple of the reference's uncertainty.
UNRESOLVED = 10.0
#: Accuracy targets of the summary table (relative error of peak stress).
TARGETS = (1e-1, 1e-2, 1e-3)
_QUANTITIES = ("peak_stress", "peak_deflection", "first_frequency")


def _merge(base: dict, override: dict) -> dict:
    out = copy.deepcopy(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def load_sweep(config: dict, root: str | Path = ".") -> dict | None:
    """The ``convergence`` block of a study config (a mapping, or the path of a YAML file in
    the project that holds one), or None.

    Parameters
    ----------
    config : dict
        Study config.
    root : path
        The project's root: relative paths are resolved against it, and the file must lie
        inside it (a study is reproducible from the project alone).

    Raises
    ------
    SceneError
        At ``convergence`` (or ``convergence.<key>``): a file that is missing, outside the
        project or unreadable (the YAML reader of :mod:`ced.problem.yaml_files`), or a block
        without one of its required keys.
    """
    block = config.get("convergence")
    if block is None:
        return None
    if isinstance(block, str):
        name, root = block, Path(root).resolve()
        path = (root / name).resolve()
        if not path.is_relative_to(root):
            raise SceneError("convergence", f"{name!r} lies outside the project ({root}); "
                                            "give a path inside it, such as "
                                            "config/studies/convergence.yaml")
        if not path.is_file():
            raise SceneError("convergence", f"{name!r} is not a file of the project")
        document = load_yaml(path, "convergence", "1.1")
        block = document.get("convergence") if isinstance(document, dict) else None
        if not isinstance(block, dict):
            raise SceneError("convergence", f"{name!r} has no 'convergence' mapping")
    for key in ("base_scene", "families", "settings", "reference", "tolerances"):
        if key not in block:
            raise SceneError(f"convergence.{key}", "missing; required keys here: base_scene, "
                                                   "families, settings, reference, tolerances")
    return block


def _as_list(value) -> list:
    return list(value) if isinstance(value, (list, tuple)) else [value]


def settings(sweep: dict) -> list[dict]:
    """The sweep's settings, each a dict of formulation, modes_per_link, integrator,
    elements_per_link and steps_per_revolution (full factorial within each entry).

    Parameters
    ----------
    sweep : dict
        The ``convergence`` block of a study config (:func:`load_sweep`).

    Returns
    -------
    list of dict
        One dict per setting.
    """
    keys = ("formulation", "modes_per_link", "integrator", "elements_per_link",
            "steps_per_revolution")
    out = []
    for entry in sweep["settings"]:
        for values in itertools.product(*(_as_list(entry[k]) for k in keys)):
            setting = dict(zip(keys, values))
            if setting not in out:
                out.append(setting)
    return out


def _scene(sweep: dict, family: str, setting: dict, **outputs) -> dict:
    scene = _merge(sweep["base_scene"], sweep["families"][family])
    scene["name"] = f"{family} reference"
    scene = _merge(scene, {
        "discretization": {"formulation": setting["formulation"],
                           "elements_per_link": int(setting["elements_per_link"]),
                           "modes_per_link": int(setting["modes_per_link"])},
        "time": {"integrator": setting["integrator"],
                 "steps_per_revolution": int(setting["steps_per_revolution"])},
        "outputs": outputs,
    })
    return scene


def _label(setting: dict) -> str:
    name = {"euler_bernoulli": "EB", "timoshenko": "Timoshenko"}.get(
        setting["formulation"], setting["formulation"])
    model = f"reduced {setting['modes_per_link']} modes" if setting["modes_per_link"] else "full"
    return f"{name} {model}, {setting['integrator']}"


def _measure(scenes: list[dict]) -> dict[str, np.ndarray]:
    """Peak stress, deflection, first frequency, estimate and time per case of one batch."""
    from ..simulation.simulate import simulate

    ds = simulate(scenes)
    out = {
        "peak_stress": ds.peak_stress.max("link").values,
        "peak_deflection": ds.peak_deflection.max("link").values,
        "first_frequency": ds.natural_frequency.isel(mode=0).mean("modal_angle").values,
        "solve_time": ds.solve_time.values,
    }
    if "error_estimate" in ds:
        out["error_estimate"] = ds.error_estimate.values
    if "discretization_auto" in ds:
        out["discretization_auto"] = ds.discretization_auto.values
    out["status"] = ds.status.values
    return out


def _reference(sweep: dict, family: str, formulation: str) -> dict[str, tuple[float, float]]:
    """(value, relative uncertainty) of each quantity for one formulation."""
    ref = sweep["reference"]
    n, s, m = ref["elements_per_link"], ref["steps_per_revolution"], ref["modes_per_link"]
    base = {"formulation": formulation, "modes_per_link": m, "integrator": "generalized_alpha"}
    levels = {}
    for key, (ne, spr) in {"fine": (n, s), "space": (n // 2, s), "time": (n, s // 2),
                           "coarse": (n // 2, s // 2), "coarse_space": (n // 4, s // 2),
                           "coarse_time": (n // 2, s // 4)}.items():
        scene = _scene(sweep, family, {**base, "elements_per_link": ne,
                                       "steps_per_revolution": spr}, error_estimate=False)
        levels[key] = _measure([scene])
    out = {}
    for q in _QUANTITIES:
        v = {k: float(levels[k][q][0]) for k in levels}
        p_space = 4 if q == "first_frequency" else 2
        fine = v["fine"] + (v["fine"] - v["space"]) / (2**p_space - 1) + (
            v["fine"] - v["time"]) / 3.0
        coarse = v["coarse"] + (v["coarse"] - v["coarse_space"]) / (2**p_space - 1) + (
            v["coarse"] - v["coarse_time"]) / 3.0
        # Known to within the larger of the extrapolation's own correction and its change
        # from one level coarser.
        spread = max(abs(fine - coarse), abs(fine - v["fine"]))
        out[q] = (fine, spread / abs(fine) if fine else 0.0)
    return out


def run_family(sweep: dict, family: str) -> "xr.Dataset":
    """Solve the sweep on one family's reference scene; see the module docstring.

    Parameters
    ----------
    sweep : dict
        The ``convergence`` block (:func:`load_sweep`).
    family : str
        One of the sweep's families.

    Returns
    -------
    xarray.Dataset
        Dimension ``setting`` (the sweep) and ``tolerance`` (the auto-discretization check);
        errors are relative and dimensionless, ``solve_time`` in s per case.
    """
    import pandas as pd
    import xarray as xr

    batch = int(sweep.get("batch", 4))
    table = settings(sweep)
    references = {f: _reference(sweep, family, f) for f in sorted({s["formulation"]
                                                                  for s in table})}
    rows = []
    for setting in table:
        # The batch times the solve; one copy carries the error estimate (solved after the
        # batch, outside its time): the others' would repeat it.
        scenes = [_scene(sweep, family, setting)] + [
            _scene(sweep, family, setting, error_estimate=False)] * (batch - 1)
        measured = _measure(scenes)
        ref = references[setting["formulation"]]
        row = {**setting, "label": _label(setting),
               "solve_time": float(np.median(measured["solve_time"])),
               "error_estimate": float(measured["error_estimate"][0]),
               "status": int(measured["status"][0])}
        for q in _QUANTITIES:
            row[q] = float(measured[q][0])
            row[f"error_{q}"] = abs(row[q] - ref[q][0]) / abs(ref[q][0])
        rows.append(row)
    frame = pd.DataFrame(rows)
    ds = xr.Dataset(coords={"setting": np.arange(len(frame))})
    for key in ("label", "formulation", "integrator"):
        ds.coords[key] = ("setting", frame[key].to_numpy(dtype=object))
    for key in ("modes_per_link", "elements_per_link", "steps_per_revolution"):
        ds.coords[key] = ("setting", frame[key].to_numpy(dtype="int32"))
    units = {"peak_stress": "Pa", "peak_deflection": "m", "first_frequency": "Hz"}
    for q in _QUANTITIES:
        ds[q] = ("setting", frame[q].to_numpy(), {"units": units[q]})
        ds[f"error_{q}"] = ("setting", frame[f"error_{q}"].to_numpy(), {
            "units": "1", "long_name": f"relative error of {q.replace('_', ' ')} vs reference"})
    ds["error_estimate"] = ("setting", frame["error_estimate"].to_numpy(), {
        "units": "1", "long_name": "ced's own estimate of the relative error of peak stress"})
    ds["solve_time"] = ("setting", frame["solve_time"].to_numpy(), {
        "units": "s", "long_name": f"solve time per case in a batch of {batch}"})
    ds["status"] = ("setting", frame["status"].to_numpy(dtype=STATUS_DTYPE),
                    {"long_name": "status flags of the setting (ced.problem.status.STATUS_FLAGS)"})
    ref = references.get("euler_bernoulli") or next(iter(references.values()))
    for q in _QUANTITIES:
        ds[f"reference_{q}"] = ((), ref[q][0], {
            "units": units[q], "uncertainty": ref[q][1],
            "long_name": f"Richardson-extrapolated {q.replace('_', ' ')} (Euler-Bernoulli)"})
    ds = ds.merge(_auto_check(sweep, family, frame, ref, batch))
    ds.attrs.update(family=family, scene=json.dumps(_merge(sweep["base_scene"],
                                                           sweep["families"][family])),
                    reference_values=json.dumps(references))
    return describe(ds)


#: Units and long names of the convergence dataset's variables without their own.
_DESCRIPTIONS = {
    "setting": ("1", "index of the discretization setting in the sweep"),
    "label": (None, "setting label: formulation, modes per link, integrator"),
    "formulation": (None, "link formulation"),
    "integrator": (None, "time integrator"),
    "modes_per_link": ("1", "component modes kept per link (0: all)"),
    "elements_per_link": ("1", "finite elements per link"),
    "steps_per_revolution": ("1", "time steps per revolution"),
    "peak_stress": ("Pa", "peak absolute stress of the reference scene"),
    "peak_deflection": ("m", "peak absolute deflection of the reference scene"),
    "first_frequency": ("Hz", "lowest natural frequency over the cycle"),
    "auto_elements_per_link": ("1", "elements per link chosen by discretization: auto"),
    "auto_steps_per_revolution": ("1", "steps per revolution chosen by discretization: auto"),
    "auto_error": ("1", "true relative error of peak stress of the auto choice"),
    "auto_error_estimate": ("1", "ced's estimate of the auto choice's relative error"),
    "cheapest_label": (None, "cheapest sweep setting meeting the tolerance (none: no setting "
                             "meets it)"),
}


def describe(ds: "xr.Dataset") -> "xr.Dataset":
    """The CF description of a convergence dataset: units and long names of every variable,
    the global attributes of ced's datasets (Conventions, title, source, history, …), no
    empty text.

    Parameters
    ----------
    ds : xarray.Dataset
        A family's convergence dataset (:func:`run_family`).

    Returns
    -------
    xarray.Dataset
        The same data, described.
    """
    import datetime

    from ..simulation.dataset import REFERENCES, source_string

    for name, (units, long_name) in _DESCRIPTIONS.items():
        if name in ds.variables:
            ds[name].attrs.setdefault("long_name", long_name)
            if units is not None:
                ds[name].attrs.setdefault("units", units)
    if "cheapest_label" in ds:
        ds["cheapest_label"] = ds.cheapest_label.copy(data=np.array(
            [str(v) or "none" for v in ds.cheapest_label.values], dtype=object))
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    ds.attrs = {"Conventions": "CF-1.12",
                "title": f"ced convergence study: {ds.attrs.get('family', '')}",
                "institution": "ced developers", "source": source_string(),
                "history": f"{now} created by ced.study.convergence", "references": REFERENCES,
                **ds.attrs}
    return ds


#: Interleaved repeats when the auto choice and the cheapest sweep settings are timed
#: against each other, and how many of the cheapest (by the sweep's timing) are re-timed.
RETIME_REPEATS, RETIME_CANDIDATES = 3, 3


def _retime(scenes: dict[str, list[dict]]) -> dict[str, float]:
    """Solve time per case of each batch, the fastest of :data:`RETIME_REPEATS` interleaved
    runs: ratios of times measured side by side are what the comparison needs. A batch
    alone (no sweep setting to compare with) is timed once: there is no ratio to protect."""
    best = {key: np.inf for key in scenes}
    for _ in range(RETIME_REPEATS if len(scenes) > 1 else 1):
        for key, batch in scenes.items():
            best[key] = min(best[key], float(np.median(_measure(batch)["solve_time"])))
    return best


def _auto_check(sweep: dict, family: str, frame: "pd.DataFrame", ref: dict,
                batch: int) -> "xr.Dataset":
    """``discretization: auto`` at each tolerance against the cheapest sweep setting.

    The chosen setting and the few cheapest sweep settings that meet the tolerance are re-timed
    side by side (:func:`_retime`), so that their ratio does not depend on the machine's load
    while the sweep ran.
    """
    import xarray as xr

    tolerances = [float(t) for t in sweep["tolerances"]]
    out = {k: [] for k in ("auto_elements_per_link", "auto_steps_per_revolution", "auto_error",
                           "auto_error_estimate", "auto_predicted_error", "auto_solve_time",
                           "cheapest_solve_time", "cheapest_error", "cheapest_label")}
    # The reference's own formulation only (auto chooses Euler–Bernoulli).
    eb = frame[frame.formulation == "euler_bernoulli"]
    for tol in tolerances:
        scene = _merge(sweep["base_scene"], sweep["families"][family])
        scene["discretization"] = "auto"
        scene["tolerance"] = tol
        measured = _measure([scene] * batch)
        choice = json.loads(str(measured["discretization_auto"][0]))
        out["auto_elements_per_link"].append(choice["elements_per_link"])
        out["auto_steps_per_revolution"].append(choice["steps_per_revolution"])
        out["auto_error"].append(abs(measured["peak_stress"][0] - ref["peak_stress"][0])
                                 / abs(ref["peak_stress"][0]))
        out["auto_error_estimate"].append(float(measured["error_estimate"][0]))
        out["auto_predicted_error"].append(float(choice["predicted_error"]))
        chosen = {"formulation": "euler_bernoulli", "modes_per_link": choice["modes_per_link"],
                  "integrator": "generalized_alpha",
                  "elements_per_link": choice["elements_per_link"],
                  "steps_per_revolution": choice["steps_per_revolution"]}
        # Timed only (their errors are known from the sweep): no error estimate, which would
        # run after each timed solve and cost more than it.
        batches = {"auto": [_scene(sweep, family, chosen, error_estimate=False)] * batch}
        meeting = eb[eb.error_peak_stress < tol].sort_values("solve_time")
        for _, row in meeting.head(RETIME_CANDIDATES).iterrows():
            setting = {k: row[k] for k in chosen}
            batches[row.label + f", {row.elements_per_link} el, "
                    f"{row.steps_per_revolution} steps"] = [
                        _scene(sweep, family, setting, error_estimate=False)] * batch
        timed = _retime(batches)
        out["auto_solve_time"].append(timed.pop("auto"))
        if timed:
            label = min(timed, key=timed.get)
            out["cheapest_solve_time"].append(timed[label])
            out["cheapest_label"].append(label)
            row = meeting.iloc[list(timed).index(label)]
            out["cheapest_error"].append(float(row.error_peak_stress))
        else:
            out["cheapest_solve_time"].append(np.nan)
            out["cheapest_error"].append(np.nan)
            out["cheapest_label"].append("")
    ds = xr.Dataset(coords={"tolerance": ("tolerance", tolerances, {
        "units": "1", "long_name": "scene tolerance (relative error of peak stress)"})})
    for key, values in out.items():
        dtype = object if key == "cheapest_label" else None
        ds[key] = ("tolerance", np.array(values, dtype=dtype))
    ds["auto_solve_time"].attrs.update(units="s", long_name="solve time per case of the "
                                       "chosen discretization (pilots excluded), timed side "
                                       "by side with the cheapest sweep settings")
    ds["cheapest_solve_time"].attrs.update(units="s", long_name="solve time per case of the "
                                           "cheapest sweep setting meeting the tolerance")
    ds["auto_predicted_error"].attrs.update(units="1", long_name="error predicted by the "
                                            "auto discretization's ladders")
    ds["cheapest_error"].attrs.update(units="1", long_name="true error of the cheapest sweep "
                                      "setting meeting the tolerance")
    ds["cost_ratio"] = ds.auto_solve_time / ds.cheapest_solve_time
    ds["cost_ratio"].attrs.update(units="1", long_name="solve time of the auto choice over "
                                  "the cheapest sweep setting meeting the tolerance")
    return ds


def accuracy_table(datasets: dict[str, "xr.Dataset"]) -> "pd.DataFrame":
    """For each family and target, the cheapest setting whose peak-stress error meets it.

    A setting meets a target where its error against the reference plus the reference's own
    relative uncertainty is below it, so that it meets the target against the exact value
    too. A target at or below that uncertainty is not verifiable: its row says so (a
    change point's reference, whose peak still moves with the step, is uncertain by ~9 %;
    an error of 0.05 % against it would say nothing about the true error).

    Parameters
    ----------
    datasets : dict of str to xarray.Dataset
        Family -> its :func:`run_family` result.

    Returns
    -------
    pandas.DataFrame
        One row per family and target relative error, with the setting, its error against the
        reference and its solve time per case (ms).
    """
    import pandas as pd

    rows = []
    for family, ds in datasets.items():
        frame = ds[["error_peak_stress", "solve_time"]].to_dataframe()
        uncertainty = _reference_uncertainty(ds)
        for target in TARGETS:
            if uncertainty >= target:
                known = (f"uncertain by {100 * uncertainty:.2g} %" if np.isfinite(uncertainty)
                         else "uncertainty unknown")
                rows.append({"family": family, "target": target,
                             "setting": f"not verifiable: reference {known}",
                             "error": np.nan, "ms_per_case": np.nan})
                continue
            meeting = frame[frame.error_peak_stress + uncertainty < target]
            if not len(meeting):
                rows.append({"family": family, "target": target, "setting": "none in the sweep",
                             "error": np.nan, "ms_per_case": np.nan})
                continue
            i = meeting.solve_time.idxmin()
            rows.append({
                "family": family, "target": target,
                "setting": (f"{ds.label.values[i]}, {int(ds.elements_per_link[i])} elements, "
                            f"{int(ds.steps_per_revolution[i])} steps/rev"),
                "error": float(frame.error_peak_stress[i]),
                "ms_per_case": 1e3 * float(frame.solve_time[i])})
    return pd.DataFrame(rows)


def _reference_uncertainty(ds: "xr.Dataset") -> float:
    """The relative uncertainty of the family's reference peak stress (0 where not stated)."""
    if "reference_peak_stress" not in ds:
        return 0.0
    value = float(ds.reference_peak_stress.attrs.get("uncertainty", 0.0))
    return value if np.isfinite(value) else np.inf


def auto_table(datasets: dict[str, "xr.Dataset"]) -> "pd.DataFrame":
    """``discretization: auto`` per family and tolerance: the choice, its predicted and true
    error, and its cost against the cheapest sweep setting meeting the same tolerance
    (``cost_ratio``, times measured side by side). ``resolved`` is False where the family's
    reference is uncertain by more than 1 % (its true errors are not known).

    Parameters
    ----------
    datasets : dict of str to xarray.Dataset
        Family -> its :func:`run_family` result.

    Returns
    -------
    pandas.DataFrame
        One row per family and tolerance.
    """
    import pandas as pd

    rows = []
    for family, ds in datasets.items():
        if "tolerance" not in ds.dims:
            continue
        resolved = _reference_uncertainty(ds) < 1e-2
        for k, tol in enumerate(ds.tolerance.values):
            pick = ds.isel(tolerance=k)
            rows.append({
                "family": family, "tolerance": float(tol),
                "setting": (f"{int(pick.auto_elements_per_link)} el, "
                            f"{int(pick.auto_steps_per_revolution)} steps/rev"),
                "predicted": float(pick.get("auto_predicted_error", np.nan)),
                "error": float(pick.auto_error), "resolved": resolved,
                "ms_per_case": 1e3 * float(pick.auto_solve_time),
                "cheapest": str(pick.cheapest_label.values),
                "cheapest_error": float(pick.get("cheapest_error", np.nan)),
                "cheapest_ms": 1e3 * float(pick.cheapest_solve_time),
                "cost_ratio": float(pick.auto_solve_time / pick.cheapest_solve_time)})
    return pd.DataFrame(rows)


def estimate_validation(datasets: dict[str, "xr.Dataset"]) -> dict[str, float]:
    """How well ``error_estimate`` brackets the true error over every setting.

    Returns ``upper_bound`` (share of settings with true ≤ estimate), ``within`` (share with
    estimate/10 ≤ true ≤ estimate), ``min_ratio`` (smallest estimate/true) and ``settings``
    (count). Settings whose true error is below ten
    times the reference's uncertainty are left out: their true error is not known well enough
    to judge an estimate by (the uncertainty is itself an estimate), and so is every setting of
    a family whose reference is uncertain by more than 1 % (the change point, whose peak
    stress depends on how close a step comes to the singular position).

    Parameters
    ----------
    datasets : dict of str to xarray.Dataset
        Family -> its :func:`run_family` result.
    """
    est, true = [], []
    for ds in datasets.values():
        floor = float(ds.reference_peak_stress.attrs["uncertainty"])
        keep = (ds.error_peak_stress.values > UNRESOLVED * floor) & (floor < 1e-2)
        est.append(ds.error_estimate.values[keep])
        true.append(ds.error_peak_stress.values[keep])
    est, true = np.concatenate(est), np.concatenate(true)
    within = (true <= est) & (true >= est / 10.0)
    return {"upper_bound": float((true <= est).mean()) if len(est) else float("nan"),
            "within": float(within.mean()) if len(est) else float("nan"),
            "min_ratio": float((est / true).min()) if len(est) else float("nan"),
            "settings": int(len(est))}
