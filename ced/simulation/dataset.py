"""The output dataset: one registry of variables, CF-1.12 metadata and provenance.

The dataset is described variable by variable in the documentation's dataset reference
(``docs/reference/dataset.md``), generated from this module by :func:`dataset_reference`.

One registry (:data:`VARIABLES`) holds the dimensions, units and long name of every variable
ced writes, so the solver only hands over arrays and the metadata stays in one place;
:func:`make_dataset` turns those arrays into a CF-described :class:`xarray.Dataset`, and
:func:`case_coordinates` describes each case by its parameters.
"""
from __future__ import annotations

import datetime as _dt
import functools
import json
import marshal
import subprocess
from pathlib import Path

import numpy as np
import xarray as xr

from .. import __version__
from ..fem.recovery import FIBRES
from ..problem.linkage import PRESET_FIELDS
from ..problem.mechanism import topology
from ..problem.status import (STATUS_ADVICE, STATUS_DTYPE, STATUS_FLAGS, STATUS_MEANINGS,
                              status_names)
from ..response.batch import Batch

__all__ = ["VARIABLES", "PRESENCE", "ESTIMATE_SOURCES", "DIMENSIONS", "CASE_COORDINATES",
           "REFERENCES", "make_dataset", "case_coordinates", "source_string",
           "dataset_reference"]

_F64, _F32 = "float64", "float32"

#: ``error_estimate_source``'s flag values (``ced.auto.sweep_estimate`` shares companions).
ESTIMATE_SOURCES = {"none": 0, "companions": 1, "discretization_auto": 2,
                    "sweep_neighbours": 3}

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
    "motion_turns": (
        ("case",), "1", "input turns after which the rigid motion repeats: 2 where it passes a "
        "change point once a turn onto the other assembly branch, else 1", "int32"),
    "deflection": (
        ("case", "step", "link", "station"), "m",
        "transverse elastic deflection relative to the deformed chord", _F32),
    "axial_displacement": (
        ("case", "step", "link", "station"), "m", "axial elastic displacement", _F32),
    "bending_strain": (
        ("case", "step", "link", "station"), "1",
        "bending strain at the outer fibre y = -h/2 (curvature times half the section depth)",
        _F32),
    "axial_strain": (("case", "step", "link", "station"), "1", "axial strain", _F32),
    "stress": (
        ("case", "step", "link", "station", "fibre"), "Pa",
        "normal stress at the outer fibre, signed (tension positive)", _F32),
    "natural_frequency": (
        ("case", "modal_angle", "mode"), "Hz", "natural frequency of the frozen linkage; "
        "negative, −√|λ|/2π, for a negative eigenvalue λ (status flag buckled)", _F64),
    "peak_deflection": (("case", "link"), "m", "peak absolute deflection over every solver "
                        "step (written or not: outputs.every)", _F64),
    "peak_stress": (("case", "link"), "Pa", "peak absolute normal stress over every solver "
                    "step (written or not: outputs.every), stations and both outer fibres", _F64),
    "dynamic_amplification": (
        ("case", "link"), "1", "peak dynamic over peak quasi-static deflection", _F64),
    "longitudinal_wave_speed": (
        ("case", "link"), "m s-1", "longitudinal wave speed sqrt((lambda + 2 mu)/rho)", _F64),
    "transverse_wave_speed": (
        ("case", "link"), "m s-1", "transverse wave speed sqrt(mu/rho)", _F64),
    "floquet_multiplier_max": (
        ("case",), "1", "largest modulus of the Floquet multipliers, per input turn (the "
        "square root of the two-turn monodromy's where the motion repeats only every two "
        "turns: a change point passed once a turn)", _F64),
    "collocation_points": (
        ("case",), "1", "Fourier collocation points per input period of the periodic steady "
        "state (0 where it was shot)", "int32"),
    "spectral_tail": (
        ("case",), "1", "summed amplitude of the highest resolved quarter of the stress "
        "harmonics, relative to the peak stress (NaN where the steady state was shot)", _F64),
    "solve_time": (("case",), "s", "solver wall time per case", _F64),
    "discretization_auto": (
        ("case",), "", "discretization chosen for the tolerance (JSON; null if not auto)", "str"),
    "error_estimate": (
        ("case",), "1",
        "estimated relative discretization error of the case's peak stress", _F64),
    "error_estimate_source": (
        ("case",), "1", "where error_estimate comes from: none (NaN), companions (the case's "
        "own coarser solutions), discretization_auto (the ladders' prediction), "
        "sweep_neighbours (a multiple of the larger estimate of the two nearest cases in "
        "speed that solved their companions: a speed sweep from a start transient)", "int8"),
    "effects_auto": (
        ("case",), "", "effects chosen by effects: auto, with the estimated relative "
        "contribution of each (JSON; null if not auto)", "str"),
    "status": (("case",), "1", "case status flags", STATUS_DTYPE),
    "message": (("case",), "", "diagnostic message: why a failed case failed, else its "
                "status flags (ok when none)", "str"),
}


_ELASTIC = "elastic formulations (not `rigid`)"
#: When each variable of :data:`VARIABLES` is in a dataset (for the generated dataset
#: reference, ``docs/reference/dataset.md``; a variable without an entry fails its test).
PRESENCE: dict[str, str] = {
    "time": "always",
    "crank_angle": "always",
    "joint_position": "always",
    "link_angle": "always",
    "link_angular_velocity": "always",
    "link_angular_acceleration": "always",
    "joint_force": "always",
    "guide_force": "slider-crank only",
    "input_torque": "always",
    "motion_turns": "always",
    "deflection": _ELASTIC,
    "axial_displacement": _ELASTIC,
    "bending_strain": _ELASTIC,
    "axial_strain": _ELASTIC,
    "stress": _ELASTIC,
    "natural_frequency": "elastic formulations with a `modal` block",
    "peak_deflection": _ELASTIC,
    "peak_stress": _ELASTIC,
    "dynamic_amplification": _ELASTIC,
    "longitudinal_wave_speed": "formulation `seed_lame` (the thesis's wave analysis)",
    "transverse_wave_speed": "formulation `seed_lame` (the thesis's wave analysis)",
    "floquet_multiplier_max": "elastic formulations with `elastic_inertia` and "
                              "`time.start: periodic`",
    "collocation_points": "elastic formulations with `elastic_inertia` and "
                          "`time.periodic_solver: spectral`",
    "spectral_tail": "elastic formulations with `elastic_inertia` and "
                     "`time.periodic_solver: spectral`",
    "solve_time": "always",
    "discretization_auto": "when a scene of the run has `discretization: auto`",
    "error_estimate": "elastic formulations unless every scene sets "
                      "`outputs.error_estimate: false`; NaN where no estimate could be made",
    "error_estimate_source": "with `error_estimate` (flag values: `flag_values`, "
                             "`flag_meanings`)",
    "effects_auto": "when a scene of the run has `effects: auto`",
    "status": "always (bit flags: `flag_masks`, `flag_meanings`)",
    "message": "always",
}

#: The dataset's dimensions: meaning and when present (for the generated reference).
DIMENSIONS: dict[str, tuple[str, str]] = {
    "case": ("one per scene, in the order given; its coordinates describe each case", "always"),
    "step": ("output time step (every `outputs.every`-th solver step)", "always"),
    "link": ("link names of the mechanism (crank, coupler, rocker; crank, rod; link)",
             "always"),
    "joint": ("joint names (A, B, C, D; A, B, C; A, B)", "always"),
    "axis": ("global axes x, y", "always"),
    "station": ("normalized position along the link, 0 (first joint) to 1 (second), "
                "`outputs.stations` evenly spaced values including 0.5", _ELASTIC),
    "fibre": ("outer fibre across the in-plane section depth, y/h = -0.5 and 0.5 (y along the "
              "link's transverse deflection axis: curvature v'' > 0 stretches the fibre at "
              "-0.5)", "with `stress`"),
    "modal_angle": ("phase of the input cycle, rad, `modal.angles` evenly spaced values (of "
                    "the two-turn period, at input angle 2 × `modal_angle`, for a case whose "
                    "motion repeats only every two turns: a change point passed once a turn)",
                    "with `natural_frequency`"),
    "mode": ("mode number 1, 2, … by ascending frequency", "with `natural_frequency`"),
}

#: Coordinates on ``case`` (:func:`case_coordinates`): name -> (units, long name, when).
CASE_COORDINATES: dict[str, tuple[str, str, str]] = {
    "family": ("", "mechanism family", "always"),
    "scene_name": ("", "scene name", "when a scene has a `name`"),
    "speed": ("rad s-1", "input speed", "always"),
    "material": ("", "material of the first flexible link (of the crank if none is); the long "
                 "name lists the links that share it", "always"),
    "ground": ("m", "ground length", "four-bar, six-bars"),
    "crank": ("m", "crank length", "four-bar, slider-crank, six-bars"),
    "coupler": ("m", "coupler length", "four-bar, six-bars"),
    "rocker": ("m", "rocker length", "four-bar, six-bars"),
    "rocker_arm": ("m", "rocker arm length D→E", "watt_ii"),
    "rocker_arm_angle": ("rad", "rocker arm angle from D→C", "watt_ii"),
    "coupler_arm": ("m", "coupler arm length B→E", "stephenson_iii"),
    "coupler_arm_angle": ("rad", "coupler arm angle from B→C", "stephenson_iii"),
    "coupler2": ("m", "second coupler length", "six-bars"),
    "rocker2": ("m", "output rocker length", "six-bars"),
    "pivot2_x": ("m", "x of the output rocker's ground pivot", "six-bars"),
    "pivot2_y": ("m", "y of the output rocker's ground pivot", "six-bars"),
    "rod": ("m", "rod length", "slider-crank"),
    "offset": ("m", "guide offset", "slider-crank"),
    "slider_mass": ("kg", "slider mass", "slider-crank"),
    "length": ("m", "link length", "single link"),
    "section_height": ("m", "section height of the first flexible link",
                       "rectangle and circle sections"),
    "section_width": ("m", "section width of the first flexible link", "rectangle sections"),
    "section_diameter": ("m", "section diameter of the first flexible link", "circle sections"),
}

#: The global ``references`` attribute: what a reader of a dataset can look up.
REFERENCES = (
    "ced documentation (docs/ in the ced repository: user guide, theory, dataset reference); "
    "D. J. A. Belenliga (1990), Analyse cinéto-élasto-dynamique des mécanismes plans à l'aide "
    "de la méthode des éléments finis, projet de fin d'études, École Polytechnique de Thiès; "
    "J. Chung and G. M. Hulbert (1993), J. Appl. Mech. 60:371-375 (generalized-alpha); "
    "R. R. Craig and M. C. C. Bampton (1968), AIAA J. 6:1313-1319 (component modes)")

@functools.cache
def _git_revision() -> str:
    """The repository revision of the code this process runs (asked once per process: two
    git calls cost ~4 ms idle, and the convergence study makes a dataset per setting)."""
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
        if name == "message" and "status" in data:  # no empty text where a value belongs
            values = np.array([m or ", ".join(status_names(int(code))) for m, code
                               in zip(values.tolist(), np.asarray(data["status"]).tolist())],
                              dtype=object)
        if dtype == "str":
            values = values.astype(object)
            if name.endswith("_auto"):  # JSON: a case not chosen automatically reads null
                values = np.array([v or "null" for v in values.tolist()], dtype=object)
        else:
            # Not copied when already stored as such (the station fields, most of the bytes,
            # come float32 from the solver; a six-bar's five links carry 5/3 of a four-bar's).
            with np.errstate(over="ignore"):  # a failed case may overflow float32: inf
                values = values.astype(dtype, copy=False)
        attrs = {"long_name": long_name}
        if dtype != "str":
            attrs["units"] = units
        if name == "status":
            attrs["flag_masks"] = np.array(
                [sum(STATUS_FLAGS.values())] + list(STATUS_FLAGS.values()), dtype=STATUS_DTYPE)
            attrs["flag_values"] = np.array([0] + list(STATUS_FLAGS.values()), dtype=STATUS_DTYPE)
            attrs["flag_meanings"] = " ".join(["ok"] + list(STATUS_FLAGS))
        if name == "error_estimate_source":
            attrs["flag_values"] = np.array(list(ESTIMATE_SOURCES.values()), dtype="int8")
            attrs["flag_meanings"] = " ".join(ESTIMATE_SOURCES)
        variables[name] = xr.Variable(dims, values, attrs)
    if any("fibre" in v.dims for v in variables.values()) and "fibre" not in coords:
        coords = {**coords, "fibre": ("fibre", np.array(FIBRES), {
            "units": "1", "long_name": "outer fibre position across the in-plane section "
                                       "depth, y/h"})}
    ds = xr.Dataset(variables, coords=coords)
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    ds.attrs = {
        "Conventions": "CF-1.12",
        "title": title,
        "institution": "ced developers",
        "source": source_string(),
        "history": f"{now} created by ced.simulate",
        "references": REFERENCES,
        "effects": " ".join(effects),
        "scenes": _scenes_json(scenes),
    }
    if extra_attrs:
        ds.attrs.update(extra_attrs)
    return ds


def _json(value) -> str:
    """Canonical JSON of the dataset's ``scenes`` attribute: sorted keys, compact."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"))


def _scenes_json(scenes: list) -> str:
    """``json.dumps(scenes, sort_keys=True, separators=(",", ":"))``, the same text, with
    each distinct top-level value of the scenes written once.

    The cases of a sweep share all but a few of their scenes' blocks (the mechanism, the
    links with their materials, the discretization), whose every float the encoder wrote as
    text again: the 64 scenes of a batch of ``benchmarks/six_bar_cost.py`` took 2.4 ms
    (four-bar) and 3.8 ms (Watt II: six links' blocks against four), now 1.2 and 1.6 ms. A
    value is known again by :mod:`marshal`'s bytes (format 2: equal bytes are equal
    structures, types and float bits, hence equal JSON); one that marshal cannot write is
    written as it is.

    Parameters
    ----------
    scenes : list
        The normalized scenes (:func:`ced.problem.scene.load_scene`).

    Returns
    -------
    str
        The JSON text of the list.
    """
    written: dict[bytes, str] = {}

    def text(value) -> str:
        try:
            key = marshal.dumps(value, 2)
        except ValueError:
            return _json(value)
        if key not in written:
            written[key] = _json(value)
        return written[key]

    names: dict[str, str] = {}  # each key's text, "name": (a call of the encoder each)
    parts = []
    for scene in scenes:
        if isinstance(scene, dict) and all(isinstance(k, str) for k in scene):
            parts.append("{" + ",".join(
                (names.get(k) or names.setdefault(k, _json(k) + ":")) + text(scene[k])
                for k in sorted(scene)) + "}")
        else:
            parts.append(_json(scene))
    return "[" + ",".join(parts) + "]"


def case_coordinates(batches: list[Batch], order: np.ndarray) -> dict:
    """Per-case parameters as coordinates on ``case`` (:data:`CASE_COORDINATES`): family, scene name, speed,
    material and section of the first flexible link, the mechanism's lengths.

    ``batches`` in the order they were solved; ``order`` restores the caller's case order.

    Parameters
    ----------
    batches : list of Batch
        The batches in the order they were solved.
    order : ndarray of int, (case,)
        Indices restoring the caller's order of the cases.

    Returns
    -------
    dict
        Coordinate name -> (``"case"``, values, attributes); units as in
        :data:`CASE_COORDINATES` (m, kg, rad s-1).
    """
    scenes = [s for b in batches for s in b.scenes]
    speeds = np.concatenate([b.speed for b in batches])
    families = [f for b in batches for f in b.families]
    kind = scenes[0]["mechanism"]["type"]
    topo = topology(scenes[0]["mechanism"])
    # The material and section of the first flexible link describe the case (all links if rigid).
    link = next((n for n in topo.links if scenes[0]["links"][n]["flexible"]), topo.link_names[0])

    def holders(key: str) -> str:
        """The links whose ``key`` (material, section) is the described one in every case."""
        same = [n for n in topo.link_names
                if all(s["links"][n][key] == s["links"][link][key] for s in scenes)]
        return ("every link" if len(same) == len(topo.link_names)
                else "the " + " and ".join(same))

    coords = {
        "family": ("case", np.array(families, dtype=object), {"long_name": "mechanism family"}),
        "speed": ("case", speeds,
                  {"units": "rad s-1", "long_name": "input speed"}),
        "material": ("case", np.array([s["links"][link]["material"]["name"] for s in scenes],
                                      dtype=object),
                     {"long_name": f"material of {holders('material')}"}),
    }
    names = [s.get("name") or "" for s in scenes]
    if any(names):  # unnamed scenes (a study's) have no name to store
        coords["scene_name"] = ("case", np.array(names, dtype=object),
                                {"long_name": "scene name"})
    for key in {"four_bar": ("ground", "crank", "coupler", "rocker"),
                "slider_crank": ("crank", "rod", "offset", "slider_mass"),
                "single_link": ("length",)}.get(kind, _six_bar_keys(scenes[0]["mechanism"])):
        units = "kg" if key == "slider_mass" else "rad" if key.endswith("angle") else "m"
        coords[key] = ("case", np.array([s["mechanism"][key] for s in scenes], float),
                       {"units": units, "long_name": f"{key.replace('_', ' ')}"})
    section = scenes[0]["links"][link]["section"]
    sections = holders("section")
    for key in ("height", "width", "diameter"):
        if key in section:
            coords[f"section_{key}"] = (
                "case", np.array([s["links"][link]["section"][key] for s in scenes], float),
                {"units": "m", "long_name": f"section {key} of {sections}"})
    return {k: (v[0], v[1][order], v[2]) for k, v in coords.items()}


def _six_bar_keys(mechanism: dict) -> tuple[str, ...]:
    """The scalar lengths and angles of a six-bar preset (none for a general linkage)."""
    fields = PRESET_FIELDS.get(mechanism["type"], {})
    return tuple(k for k in fields if isinstance(mechanism[k], float))


def dataset_reference() -> str:
    """The dataset reference page (Markdown), generated from :data:`VARIABLES`,
    :data:`PRESENCE`, :data:`DIMENSIONS`, :data:`CASE_COORDINATES` and the status flags.

    Returns
    -------
    str
        The text of ``docs/reference/dataset.md``, ending with a newline.

    Raises
    ------
    KeyError
        If a variable has no :data:`PRESENCE` entry or uses a dimension missing from
        :data:`DIMENSIONS`.
    """
    from ..problem.reference import markdown_table

    dims = [[name, meaning, when] for name, (meaning, when) in DIMENSIONS.items()]
    coords = [[name, units or "—", long_name, when]
              for name, (units, long_name, when) in CASE_COORDINATES.items()]
    variables = []
    for name, (vdims, units, long_name, dtype) in VARIABLES.items():
        for dim in vdims:
            DIMENSIONS[dim]  # noqa: B018 — every dimension is documented
        variables.append([name, "(" + ", ".join(vdims) + ")", units or "—",
                          "text" if dtype == "str" else dtype, long_name, PRESENCE[name]])
    flags = [["ok", "0", "no flag set", "nothing"]] + [
        [name, str(bit), STATUS_MEANINGS[name], STATUS_ADVICE[name]]
        for name, bit in STATUS_FLAGS.items()]
    parts = [
        "# Dataset reference",
        "",
        "<!-- Generated by `make reference` from "
        "`ced/simulation/dataset.py` and `ced/problem/status.py`; do not edit by hand "
        "(`tests/test_docs_reference.py` fails when this page is out of date). -->",
        "",
        "`ced run`, `ced.simulate` and every chunk of a study write one CF-1.12 netCDF dataset "
        "(open it with `xarray.open_dataset`). Units follow UDUNITS (`rad s-1`); `1` is "
        "dimensionless; text variables have no units. Station fields are stored as float32, "
        "everything else as float64.",
        "",
        "## Dimensions",
        "",
        markdown_table(["dimension", "meaning", "present"], dims),
        "",
        "## Coordinates on `case`",
        "",
        "Each case is described by its parameters, as coordinates along `case` (select with "
        "`ds.where(ds.family == 'crank_rocker', drop=True)` or `ds.swap_dims(case='speed')`). "
        "The dimension coordinates are `case` (index), `step` (solver step index), `link`, "
        "`joint`, `axis` (x, y), `station` (0…1), `fibre` (y/h), `modal_angle` (rad) and "
        "`mode`.",
        "",
        "In the file, a dimension labelled by text (`link`, `joint`, `axis`, and `material` in "
        "a study's grid maps) is an integer index, as CF requires of coordinate variables, "
        "with the labels as the auxiliary coordinate `link_name` (`joint_name`, …). "
        "`ced.open_dataset(path)` (`ced.io.open_dataset`) restores the labels as the index, "
        "so that selecting by name stays one call: "
        "`ced.open_dataset('run.nc').stress.sel(link='coupler', fibre=0.5)`. With plain "
        "xarray, `ds.swap_dims(link='link_name')` does the same.",
        "",
        markdown_table(["coordinate", "units", "meaning", "present"], coords),
        "",
        "## Variables",
        "",
        markdown_table(["variable", "dims", "units", "type", "meaning", "present"], variables),
        "",
        "## `status` flags",
        "",
        "`status` is a bit field (CF `flag_masks`, `flag_meanings`); a case is `ok` when no "
        "bit is set. Read it with `ced.problem.status.status_names(int(code))`.",
        "",
        "<!-- status flags: start -->",
        "",
        markdown_table(["flag", "bit", "meaning", "what to do"], flags),
        "",
        "<!-- status flags: end -->",
        "",
        "## Global attributes",
        "",
        "`Conventions` (CF-1.12), `title`, `institution`, `source` (ced version and git "
        "revision), `history` (creation time), `references`, `effects` (the effects "
        "simulated, space-separated) and `scenes` (the normalized scene of every case, as "
        "JSON: `json.loads(ds.attrs['scenes'])`). The `references` attribute reads:",
        "",
        f"> {REFERENCES}",
        "",
    ]
    return "\n".join(parts)
