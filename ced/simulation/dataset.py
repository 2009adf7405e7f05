"""The output dataset: one registry of variables, CF-1.12 metadata and provenance (DESIGN §5).

One registry (:data:`VARIABLES`) holds the dimensions, units and long name of every variable
ced writes, so the solver only hands over arrays and the metadata stays in one place;
:func:`make_dataset` turns those arrays into a CF-described :class:`xarray.Dataset`, and
:func:`case_coordinates` describes each case by its parameters.
"""
from __future__ import annotations

import datetime as _dt
import json
import subprocess
from pathlib import Path

import numpy as np
import xarray as xr

from .. import __version__
from ..problem.mechanism import topology
from ..problem.status import STATUS_DTYPE, STATUS_FLAGS
from ..response.batch import Batch

__all__ = ["VARIABLES", "make_dataset", "case_coordinates", "source_string"]

_F64, _F32 = "float64", "float32"

#: name -> (dims, units, long_name, dtype)
VARIABLES: dict[str, tuple[tuple[str, ...], str, str, str]] = {
    "time": (("case", "step"), "s", "time since the start of the motion", _F64),
    "crank_angle": (("case", "step"), "rad", "input link angle", _F64),
    "joint_position": (("case", "step", "joint", "axis"), "m", "joint position", _F64),
    "link_angle": (("case", "step", "link"), "rad", "link angle from +x, counter-clockwise", _F64),
    "link_angular_velocity": (("case", "step", "link"), "rad s-1", "link angular velocity", _F64),
    "link_angular_acceleration": (
        ("case", "step", "link"), "rad s-2", "link angular acceleration", _F64),
    "joint_force": (
        ("case", "step", "joint", "axis"), "N",
        "force on the second body of the joint exerted by the first", _F64),
    "guide_force": (
        ("case", "step"), "N", "normal force of the guide on the slider (y component)", _F64),
    "input_torque": (
        ("case", "step"), "N m", "torque applied by the drive to the input link", _F64),
    "deflection": (
        ("case", "step", "link", "station"), "m",
        "transverse elastic deflection relative to the deformed chord", _F32),
    "axial_displacement": (
        ("case", "step", "link", "station"), "m", "axial elastic displacement", _F32),
    "bending_strain": (
        ("case", "step", "link", "station"), "1", "outer-fibre bending strain", _F32),
    "axial_strain": (("case", "step", "link", "station"), "1", "axial strain", _F32),
    "stress": (
        ("case", "step", "link", "station"), "Pa",
        "normal stress at the outer fibre of larger magnitude", _F32),
    "natural_frequency": (
        ("case", "modal_angle", "mode"), "Hz", "natural frequency of the frozen linkage; "
        "negative, −√|λ|/2π, for a negative eigenvalue λ (status flag buckled)", _F64),
    "peak_deflection": (("case", "link"), "m", "peak absolute deflection", _F64),
    "peak_stress": (("case", "link"), "Pa", "peak absolute stress", _F64),
    "dynamic_amplification": (
        ("case", "link"), "1", "peak dynamic over peak quasi-static deflection", _F64),
    "longitudinal_wave_speed": (
        ("case", "link"), "m s-1", "longitudinal wave speed sqrt((lambda + 2 mu)/rho)", _F64),
    "transverse_wave_speed": (
        ("case", "link"), "m s-1", "transverse wave speed sqrt(mu/rho)", _F64),
    "floquet_multiplier_max": (
        ("case",), "1", "largest modulus of the Floquet multipliers", _F64),
    "solve_time": (("case",), "s", "solver wall time per case", _F64),
    "discretization_auto": (
        ("case",), "", "discretization chosen for the tolerance (JSON; empty if not auto)", "str"),
    "error_estimate": (
        ("case",), "1",
        "estimated relative discretization error of the case's peak stress", _F64),
    "effects_auto": (
        ("case",), "", "effects chosen by effects: auto, with the estimated relative "
        "contribution of each (JSON)", "str"),
    "status": (("case",), "1", "case status flags", STATUS_DTYPE),
    "message": (("case",), "", "diagnostic message", "str"),
}


def _git_revision() -> str:
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(
            ["git", "rev-parse", "--short=12", "HEAD"], cwd=here, capture_output=True,
            text=True, timeout=5,
        )
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"], cwd=here,
            capture_output=True, text=True, timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    if out.returncode != 0:
        return "unknown"
    return out.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")


def source_string() -> str:
    """``ced <version> (git <revision>)`` for the CF ``source`` attribute."""
    return f"ced {__version__} (git {_git_revision()})"


def make_dataset(
    data: dict[str, np.ndarray],
    coords: dict[str, object],
    *,
    scenes: list[dict],
    effects: list[str],
    title: str = "ced kineto-elasto-dynamic analysis",
    extra_attrs: dict | None = None,
) -> xr.Dataset:
    """Build a CF-described dataset from arrays named as in :data:`VARIABLES`.

    Parameters
    ----------
    data : variable name -> array with the registry's dimensions
    coords : coordinate name -> array or (dims, array[, attrs]) tuple
    scenes : the normalized scenes of the cases (stored as JSON)
    effects : effect names that were simulated
    """
    variables = {}
    for name, values in data.items():
        dims, units, long_name, dtype = VARIABLES[name]
        values = np.asarray(values)
        if dtype == "str":
            values = values.astype(object)
        else:
            with np.errstate(over="ignore"):  # a failed case may overflow float32: inf
                values = values.astype(dtype)
        attrs = {"long_name": long_name}
        if dtype != "str":
            attrs["units"] = units
        if name == "status":
            attrs["flag_masks"] = np.array(
                [sum(STATUS_FLAGS.values())] + list(STATUS_FLAGS.values()), dtype=STATUS_DTYPE)
            attrs["flag_values"] = np.array([0] + list(STATUS_FLAGS.values()), dtype=STATUS_DTYPE)
            attrs["flag_meanings"] = " ".join(["ok"] + list(STATUS_FLAGS))
        variables[name] = xr.Variable(dims, values, attrs)
    ds = xr.Dataset(variables, coords=coords)
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    ds.attrs = {
        "Conventions": "CF-1.12",
        "title": title,
        "institution": "ced developers",
        "source": source_string(),
        "history": f"{now} created by ced.simulate",
        "references": "Belenliga (1990), Analyse cinéto-élasto-dynamique des mécanismes plans "
        "à l'aide de la méthode des éléments finis, École Polytechnique de Thiès; "
        "ced DESIGN.md",
        "effects": " ".join(effects),
        "scenes": json.dumps(scenes, sort_keys=True, separators=(",", ":")),
    }
    if extra_attrs:
        ds.attrs.update(extra_attrs)
    return ds


def case_coordinates(batches: list[Batch], order: np.ndarray) -> dict:
    """Per-case parameters as coordinates on ``case`` (DESIGN §5): family, scene name, speed,
    material and section of the first flexible link, the mechanism's lengths.

    ``batches`` in the order they were solved; ``order`` restores the caller's case order.
    """
    scenes = [s for b in batches for s in b.scenes]
    speeds = np.concatenate([b.speed for b in batches])
    families = [f for b in batches for f in b.families]
    kind = scenes[0]["mechanism"]["type"]
    topo = topology(kind)
    # The material and section of the first flexible link describe the case (all links if rigid).
    link = next((n for n in topo.links if scenes[0]["links"][n]["flexible"]), topo.link_names[0])
    coords = {
        "family": ("case", np.array(families, dtype=object), {"long_name": "mechanism family"}),
        "scene_name": ("case", np.array([s.get("name", "") for s in scenes], dtype=object),
                       {"long_name": "scene name"}),
        "speed": ("case", speeds,
                  {"units": "rad s-1", "long_name": "input speed"}),
        "material": ("case", np.array([s["links"][link]["material"]["name"] for s in scenes],
                                      dtype=object),
                     {"long_name": f"material of the {link}"}),
    }
    for key in {"four_bar": ("ground", "crank", "coupler", "rocker"),
                "slider_crank": ("crank", "rod", "offset", "slider_mass"),
                "single_link": ("length",)}[kind]:
        units = "kg" if key == "slider_mass" else "m"
        coords[key] = ("case", np.array([s["mechanism"][key] for s in scenes], float),
                       {"units": units, "long_name": f"{key.replace('_', ' ')}"})
    section = scenes[0]["links"][link]["section"]
    for key in ("height", "width", "diameter"):
        if key in section:
            coords[f"section_{key}"] = (
                "case", np.array([s["links"][link]["section"][key] for s in scenes], float),
                {"units": "m", "long_name": f"section {key} of the {link}"})
    return {k: (v[0], v[1][order], v[2]) for k, v in coords.items()}
