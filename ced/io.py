"""Output datasets: CF-1.12 metadata, provenance, atomic netCDF writes (DESIGN §5).

One registry (:data:`VARIABLES`) holds the dimensions, units and long name of every variable
ced writes, so the solver only hands over arrays and the metadata stays in one place.
"""
from __future__ import annotations

import datetime as _dt
import json
import os
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr

from . import __version__

__all__ = [
    "VARIABLES",
    "STATUS_FLAGS",
    "status_code",
    "status_names",
    "make_dataset",
    "write_dataset",
    "source_string",
]

#: Bit of each status flag; "ok" is the absence of every other bit (CF flag_masks+flag_values).
STATUS_FLAGS = {
    "large_deflection": 1,
    "near_singular": 2,
    "resonant": 4,
    "parametrically_unstable": 8,
    "failed": 16,
    "not_assemblable": 32,
    # The frozen structure K_eff has a negative eigenvalue at some phase (a link compressed
    # beyond its Euler load, or centrifugal softening of a near-mechanism mode): reported as
    # a negative natural_frequency, −√|λ|/2π (ced.modal, ced.ked._buckled).
    "buckled": 64,
    # discretization: auto could not reach the scene's tolerance within its ladders' limits
    # (ced.discretize): the error estimate says by how much.
    "tolerance_unmet": 128,
}

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
        ("case", "modal_angle", "mode"), "Hz", "natural frequency of the frozen linkage; negative, −√|λ|/2π, for a negative "
        "eigenvalue λ (status flag buckled)", _F64),
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
    "status": (("case",), "1", "case status flags", "uint8"),
    "message": (("case",), "", "diagnostic message", "str"),
}


def status_code(flags) -> int:
    """Combine flag names into a status code (0 is ok)."""
    code = 0
    for name in flags:
        code |= STATUS_FLAGS[name]
    return code


def status_names(code: int) -> list[str]:
    """Flag names set in a status code; ``["ok"]`` for 0."""
    names = [n for n, bit in STATUS_FLAGS.items() if code & bit]
    return names or ["ok"]


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
            values = values.astype(dtype)
        attrs = {"long_name": long_name}
        if dtype != "str":
            attrs["units"] = units
        if name == "status":
            attrs["flag_masks"] = np.array(
                [sum(STATUS_FLAGS.values())] + list(STATUS_FLAGS.values()), dtype="uint8")
            attrs["flag_values"] = np.array([0] + list(STATUS_FLAGS.values()), dtype="uint8")
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


def _encoding(ds: xr.Dataset) -> dict:
    encoding = {}
    for name, var in ds.variables.items():
        if var.dtype.kind in "OUS":
            continue  # variable-length strings cannot be compressed in netCDF4
        enc = {"zlib": True, "complevel": 4, "shuffle": True}
        if "case" in var.dims and var.ndim > 0:
            enc["chunksizes"] = tuple(
                min(64, n) if d == "case" else n for d, n in zip(var.dims, var.shape)
            )
        if var.dtype.kind == "f":
            enc["_FillValue"] = None  # no silent NaN fill: every value is computed
        encoding[name] = enc
    return encoding


def write_dataset(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write ``ds`` to ``path`` atomically (temporary file in the same directory, then rename).

    Overwriting an open file in place can truncate it (xarray #10679); a reader either sees the
    old file or the complete new one, and a write killed half way leaves only a temp file,
    which the next successful write of the same path removes.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=_encoding(ds))
        # mkstemp creates 0600; give the result the permissions a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    # A write killed earlier (SIGKILL, node failure) left its temp file; the complete file now
    # exists, so those leftovers are garbage. One job writes a given output, so none is live.
    for stale in path.parent.glob(f".{path.name}.*.tmp"):
        stale.unlink(missing_ok=True)
    return path
