"""The case table of a study config and its chunks.

The case table is a pure, deterministic function of the config (docs/reference/config.md): the cartesian
product of the grids, each geometry classified (Grashof) into its family, filtered by the
families to keep, in a fixed order (mechanism type, then the length grids in the order of
:data:`GRID_KEYS`, then speed, material, section). A case's id is its position among the
cases of its family, so chunk files of one family concatenate without clashes, and a job is
named by (family, chunk index) — never by a float.

Building the table is cheap (the Grashof classification of each geometry); the scenes are
built only for the rows asked for, so the Snakefile can call :func:`chunks` at parse time.

The config is validated first (:mod:`ced.study.config`); the functions here assume a valid
one. :func:`ced.study.chunk_job.run_chunk` simulates one chunk.

Examples
--------
>>> config = {"grids": {"four_bar": {"ground": 0.5, "crank": [0.1, 0.2],
...                                  "coupler": [0.45], "rocker": [0.35]}},
...           "speeds": [50.0, 100.0], "materials": ["steel"],
...           "sections": [{"shape": "rectangle", "height": 0.005, "width": 0.01}],
...           "chunk_size": 3}
>>> chunks(config)
{'crank_rocker': 2}
>>> [(r["case"], r["crank"], r["speed"]) for r in case_table(config)]
[(0, 0.1, 50.0), (1, 0.1, 100.0), (2, 0.2, 50.0), (3, 0.2, 100.0)]
"""
from __future__ import annotations

import copy
import itertools
import math
from collections.abc import Mapping

import numpy as np

from ..problem.errors import SceneError
from ..problem.linkage import four_bar_loops
from ..problem.materials import resolve_material
from ..problem.mechanism import assembly_error, classify
from ..problem.scene import BLOCKS

__all__ = [
    "GRID_KEYS",
    "FIXED_KEYS",
    "SIX_BARS",
    "CASE_KEYS",
    "six_bar_family",
    "family_kept",
    "drive_amplitude",
    "geometry_counts",
    "split_geometries",
    "grid_geometries",
    "grid_values",
    "grid_axes",
    "axis_length",
    "grid_points",
    "assemblable_geometries",
    "kept_geometries",
    "inner_points",
    "material_names",
    "scene_for",
    "case_row",
    "case_table",
    "family_sizes",
    "chunks",
    "chunk_rows",
    "chunk_scenes",
    "case_config",
    "modal_requested",
    "estimate_requested",
    "study_size",
]


#: Six-bar presets a study can grid (docs/guide/six_bars.md).
SIX_BARS = ("watt_ii", "stephenson_iii")
_SECOND_LOOP = ("coupler2", "rocker2", "pivot2_x", "pivot2_y")
#: Keys spanned by the grids of each mechanism type (lengths in m, angles in rad), in
#: case-table order.
GRID_KEYS = {
    "four_bar": ("crank", "coupler", "rocker"),
    "slider_crank": ("crank", "rod", "offset"),
    "watt_ii": ("crank", "coupler", "rocker", "rocker_arm", "rocker_arm_angle", *_SECOND_LOOP),
    "stephenson_iii": ("crank", "coupler", "rocker", "coupler_arm", "coupler_arm_angle",
                       *_SECOND_LOOP),
}
#: Keys of a mechanism type's grid block that take one value for the whole study (the
#: ground length is one so that a family's maps share their frame; a branch is a choice).
FIXED_KEYS = {
    "four_bar": ("ground",),
    "slider_crank": ("slider_mass",),
    "watt_ii": ("ground", "branch", "branch2"),
    "stephenson_iii": ("ground", "branch", "branch2"),
}
#: Config keys that define the cases (and so the chunk files); the rest (study name, families
#: kept, reduction settings) can change without re-simulating anything.
CASE_KEYS = ("grids", "speeds", "materials", "sections", "chunk_size", "base_scene")


def grid_values(spec, path: str = "grid") -> list[float]:
    """The values of one grid axis.

    Parameters
    ----------
    spec : number, list of numbers, or mapping ``{start, stop, num}``
        A single value, explicit values (kept in the order given), or ``num`` evenly spaced
        values from ``start`` to ``stop`` inclusive.
    path : str
        Key path for error messages.

    Examples
    --------
    >>> grid_values({"start": 0.1, "stop": 0.3, "num": 3})
    [0.1, 0.2, 0.3]
    >>> grid_values([0.3, 0.1]), grid_values(0.5)
    ([0.3, 0.1], [0.5])
    """
    if isinstance(spec, Mapping):
        missing = [k for k in ("start", "stop", "num") if k not in spec]
        if missing or set(spec) - {"start", "stop", "num"}:
            raise SceneError(path, "a range must have exactly the keys start, stop, num")
        num = spec["num"]
        if isinstance(num, bool) or not isinstance(num, int) or num < 1:
            raise SceneError(f"{path}.num", f"must be an integer >= 1, got {num!r}")
        values = np.linspace(float(spec["start"]), float(spec["stop"]), num)
        # Round away the last-bit noise of linspace so that equal lengths compare equal
        # (S + L = P + Q for change points) and print as given.
        return [float(f"{v:.12g}") for v in values]
    if isinstance(spec, (list, tuple)):
        if not spec:
            raise SceneError(path, "must not be empty")
        values = list(spec)
    else:
        values = [spec]
    for i, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise SceneError(f"{path}[{i}]" if isinstance(spec, (list, tuple)) else path,
                             f"must be a finite number, got {v!r}")
    return [float(v) for v in values]


def six_bar_family(mechanism: Mapping) -> str:
    """Study family of a six-bar: its type and the Grashof type of each four-bar loop.

    A ``watt_ii`` has two four-bar loops (A–B–C–D, then D–E–F–G driven by the rocker's arm),
    a ``stephenson_iii`` one (its second loop is a five-bar,
    :func:`ced.problem.linkage.four_bar_loops`); the parts are joined by ``-``.

    Parameters
    ----------
    mechanism : mapping
        A six-bar mechanism block (type, lengths in m, angles in rad).

    Returns
    -------
    str
        e.g. ``watt_ii-crank_rocker-triple_rocker``, ``stephenson_iii-crank_rocker``.

    Examples
    --------
    >>> six_bar_family({"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
    ...                 "rocker": 0.35, "rocker_arm": 0.25, "rocker_arm_angle": 2.5,
    ...                 "coupler2": 0.4, "rocker2": 0.3, "pivot2_x": 0.2, "pivot2_y": -0.3})
    'watt_ii-crank_rocker-crank_rocker'
    """
    loops = [classify(*loop) for loop in four_bar_loops(mechanism)]
    return "-".join([mechanism["type"], *loops])


def drive_amplitude(config: dict) -> float:
    """``drive.amplitude`` of the base scene (the scene default if not given): the fraction of
    a rocker input's feasible half-range its oscillation sweeps, over which a six-bar with a
    rocker-input first loop must assemble.

    Parameters
    ----------
    config : dict
        A study config.

    Returns
    -------
    float
        The amplitude (1.0 if the base scene's value is not a number in (0, 1]: its scene
        check reports that).
    """
    drive = (config.get("base_scene") or {}).get("drive") or {}
    amplitude = drive.get("amplitude", BLOCKS["drive"]["amplitude"][1])
    valid = (isinstance(amplitude, (int, float)) and not isinstance(amplitude, bool)
             and 0.0 < amplitude <= 1.0)
    return float(amplitude) if valid else 1.0


def grid_geometries(config: dict, kind: str):
    """(lengths, mechanism block) of every grid geometry of one mechanism type, in table order.

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).
    kind : str
        A mechanism type of :data:`GRID_KEYS` (none if the config has no grid of it).

    Yields
    ------
    lengths : dict
        The geometry's grid values and fixed ground length (the case coordinates).
    mechanism : dict
        Its mechanism block for :func:`ced.problem.mechanism.assembly_error` (with the
        branches of a six-bar).
    """
    grid = config.get("grids", {}).get(kind)
    if not grid:
        return
    keys = GRID_KEYS[kind]
    axes = [grid_values(grid.get(k, [0.0]), f"grids.{kind}.{k}") for k in keys]
    fixed = {k: grid[k] for k in FIXED_KEYS[kind] if k in grid}
    for values in itertools.product(*axes):
        lengths = dict(zip(keys, values))
        if "ground" in fixed:
            lengths = {"ground": float(fixed["ground"]), **lengths}
        mechanism = {"type": kind, **lengths}
        if kind in SIX_BARS:
            mechanism.update(branch=fixed.get("branch", "open"),
                             branch2=fixed.get("branch2", "open"))
        yield lengths, mechanism


def _family_of(kind: str, lengths: dict, mechanism: dict) -> str:
    if kind == "four_bar":
        return classify(**lengths)
    return six_bar_family(mechanism) if kind in SIX_BARS else kind


def split_geometries(config: dict) -> tuple[list[tuple[str, str, dict]], dict[str, int]]:
    """Assemblable geometries (as :func:`assemblable_geometries`) and, per mechanism type,
    the number of grid geometries that cannot be assembled.

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    list of (str, str, dict)
        :func:`assemblable_geometries`.
    dict of str to int
        Geometries refused per mechanism type (only types with some).
    """
    out, refused = [], {}
    amplitude = drive_amplitude(config)
    for kind in GRID_KEYS:
        for lengths, mechanism in grid_geometries(config, kind):
            if assembly_error(mechanism, amplitude):
                refused[kind] = refused.get(kind, 0) + 1
                continue
            out.append((kind, _family_of(kind, lengths, mechanism), lengths))
    return out, refused


def assemblable_geometries(config: dict) -> list[tuple[str, str, dict]]:
    """(mechanism type, family, lengths) of every assemblable geometry of the grids, in table
    order, whatever the families kept.

    A six-bar must assemble over the whole motion of its input (a full turn, or the rocker
    input's oscillation of ``base_scene.drive.amplitude``), as its scene requires
    (:func:`ced.problem.mechanism.assembly_error`); its family is :func:`six_bar_family`.

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    list of (str, str, dict)
        Mechanism type, family and lengths (m; six-bar angles in rad) of each geometry.
    """
    return split_geometries(config)[0]


def geometry_counts(config: dict) -> dict[str, dict[str, int]]:
    """Grid geometries of each mechanism type of the study: in total, assemblable, refused
    (cannot be assembled over the whole input motion) and kept (in the families asked for).

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    dict of str to dict
        ``{kind: {"grid": n, "not_assemblable": n, "kept": n}}`` for each type in ``grids``.
    """
    geometries, refused = split_geometries(config)
    kept = _kept(config, geometries)
    counts = {}
    for kind in GRID_KEYS:
        if not config.get("grids", {}).get(kind):
            continue
        good = sum(g[0] == kind for g in geometries)
        counts[kind] = {"grid": good + refused.get(kind, 0),
                        "not_assemblable": refused.get(kind, 0),
                        "kept": sum(g[0] == kind for g in kept)}
    return counts


def family_kept(config: dict, kind: str, family: str) -> bool:
    """Whether the study keeps a family: named in ``families``, or a six-bar family whose
    type is named there alone (``watt_ii`` keeps every Watt II family); every family if the
    config has no ``families`` (the case part of a config, :func:`case_config`).

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).
    kind, family : str
        Mechanism type and family of a geometry.

    Returns
    -------
    bool
    """
    keep = config.get("families")
    if keep is None:  # a chunk job's config (case_config): every family
        return True
    return family in keep or (kind in SIX_BARS and kind in keep)


def _kept(config: dict, geometries: list) -> list[tuple[str, str, dict]]:
    return [g for g in geometries if family_kept(config, g[0], g[1])]


def kept_geometries(config: dict) -> list[tuple[str, str, dict]]:
    """(mechanism type, family, lengths) of every assemblable geometry kept, in table order.

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    list of (str, str, dict)
        Mechanism type, family and lengths (m) of each geometry.
    """
    return _kept(config, assemblable_geometries(config))


def inner_points(config: dict) -> list[tuple[float, int, int]]:
    """(speed, material index, section index) of each case of one geometry, in table order.

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    list of (float, int, int)
        Speed (rad/s), material index and section index.
    """
    speeds = grid_values(config["speeds"], "speeds")
    return list(itertools.product(
        speeds, range(len(config["materials"])), range(len(config["sections"]))))


def material_names(config: dict) -> list[str]:
    """Resolved names of the study's materials (library aliases mapped to the library name).

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    list of str
        One name per entry of ``config["materials"]``.
    """
    return [resolve_material(m, f"materials[{i}]")["name"]
            for i, m in enumerate(config["materials"])]


def scene_for(config: dict, kind: str, lengths: dict, speed: float, material,
               section: dict) -> dict:
    """The (un-normalized) scene of one case: the base scene with the case's mechanism,
    material (of every link, through ``links.default``), section and speed.

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).
    kind : str
        Mechanism type.
    lengths : dict
        Mechanism lengths (and slider mass), m (kg).
    speed : float
        Input speed, rad/s.
    material : str or dict
        Library name or inline material.
    section : dict
        Cross-section.

    Returns
    -------
    dict
        A scene for :func:`ced.problem.scene.load_scene`.
    """
    base = copy.deepcopy(config.get("base_scene") or {})
    # Keys of a base mechanism block other than type and lengths (e.g. branch) carry over.
    grid = config["grids"][kind]
    mechanism = {k: v for k, v in (base.get("mechanism") or {}).items()
                 if k not in ("type", "ground", *FIXED_KEYS[kind], *GRID_KEYS[kind])}
    mechanism.update({"type": kind, **lengths})
    if kind == "slider_crank":
        mechanism["slider_mass"] = float(grid.get("slider_mass", 0.0))
    mechanism.update({k: grid[k] for k in ("branch", "branch2")
                      if k in FIXED_KEYS[kind] and k in grid})
    base["mechanism"] = mechanism
    # A null block is a scene's defaults (load_scene reads it so): filled in here like an
    # absent one (a block that is no mapping is refused by the config's validation).
    links = base["links"] = base.get("links") or {}
    default = links["default"] = links.get("default") or {}
    default["material"] = copy.deepcopy(material)
    default["section"] = dict(section)
    drive = base["drive"] = base.get("drive") or {}
    drive["speed"] = speed
    return base


def case_row(config: dict, kind: str, family: str, lengths: dict, case: int,
         inner: tuple[float, int, int], names: list[str], scene: bool) -> dict:
    """One row of the case table (see :func:`case_table`).

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).
    kind, family : str
        Mechanism type and family.
    lengths : dict
        Mechanism lengths, m.
    case : int
        Case id within the family.
    inner : (float, int, int)
        Speed (rad/s), material index, section index.
    names : list of str
        Resolved material names (:func:`material_names`).
    scene : bool
        Whether to build the row's scene.

    Returns
    -------
    dict
        The row.
    """
    speed, m, s = inner
    material = config["materials"][m]
    row = {"case": case, "family": family, "mechanism": kind, **lengths, "speed": speed,
           "material": names[m], "material_index": m, "section": s}
    if scene:
        row["scene"] = scene_for(config, kind, lengths, speed, material, config["sections"][s])
    return row


def case_table(config: dict, family: str | None = None, *, scenes: bool = True) -> list[dict]:
    """Every case of the study (or of one ``family``), in a deterministic order.

    Each row: ``case`` (id within the family), ``family``, ``mechanism`` (type), the lengths,
    ``speed``, ``material`` (resolved name), ``material_index``, ``section`` (index into the
    config's sections) and, if ``scenes``, ``scene`` (an un-normalized scene dict). Linkages
    that cannot be assembled are dropped, as are families not in ``config["families"]``.

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).
    family : str, optional
        Only this family's cases.
    scenes : bool
        Whether to build each row's scene (slower).

    Returns
    -------
    list of dict
        The rows.
    """
    inner, names = inner_points(config), material_names(config)
    counters: dict[str, int] = {}
    rows = []
    for kind, fam, lengths in kept_geometries(config):
        if family is not None and fam != family:
            continue
        for point in inner:
            case = counters.get(fam, 0)
            counters[fam] = case + 1
            rows.append(case_row(config, kind, fam, lengths, case, point, names, scenes))
    return rows


def family_sizes(config: dict) -> dict[str, int]:
    """Number of cases of each family present in the study (families in table order).

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    dict of str to int
        Cases per family.
    """
    n = len(inner_points(config))
    sizes: dict[str, int] = {}
    for _, family, _ in kept_geometries(config):
        sizes[family] = sizes.get(family, 0) + n
    return sizes


def study_size(config: dict) -> int:
    """Number of grid points before assembly check and classification (:func:`grid_points`).

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    int
        Grid points.
    """
    return grid_points(config)


def chunks(config: dict) -> dict[str, int]:
    """Number of chunks of each family present in the study.

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    dict of str to int
        Chunk jobs per family (``ceil(cases / chunk_size)``).
    """
    size = int(config["chunk_size"])
    return {f: math.ceil(n / size) for f, n in family_sizes(config).items()}


def chunk_rows(config: dict, family: str, index: int, *, scenes: bool = True) -> list[dict]:
    """Rows of chunk ``index`` of ``family`` (scenes are built for these rows only).

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).
    family : str
        The family.
    index : int
        The chunk's index within the family, from 0.
    scenes : bool
        Whether to build each row's scene.

    Returns
    -------
    list of dict
        The chunk's rows of :func:`case_table`.
    """
    size = int(config["chunk_size"])
    inner, names = inner_points(config), material_names(config)
    geometries = [g for g in kept_geometries(config) if g[1] == family]
    first, last = index * size, min((index + 1) * size, len(geometries) * len(inner))
    if index < 0 or first >= last:
        raise SceneError("chunk", f"family {family!r} has no chunk {index}")
    rows = []
    for case in range(first, last):
        kind, fam, lengths = geometries[case // len(inner)]
        rows.append(case_row(config, kind, fam, lengths, case, inner[case % len(inner)], names,
                         scenes))
    return rows


def chunk_scenes(config: dict, family: str, index: int) -> list[dict]:
    """Scenes of chunk ``index`` of ``family``.

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).
    family : str
        The family.
    index : int
        The chunk's index within the family, from 0.

    Returns
    -------
    list of dict
        Un-normalized scenes, one per case.
    """
    return [r["scene"] for r in chunk_rows(config, family, index)]


def case_config(config: dict) -> dict:
    """The part of ``config`` that defines the cases (:data:`CASE_KEYS`).

    Passed to the simulation jobs as their ``params``, so that editing the study name, the
    families kept or a reduction setting re-runs no simulation.

    Parameters
    ----------
    config : dict
        A study config.

    Returns
    -------
    dict
        The keys of :data:`CASE_KEYS` that ``config`` has.
    """
    return {k: copy.deepcopy(config[k]) for k in CASE_KEYS if k in config}


def _elastic(base: dict) -> bool:
    """Whether a base scene's discretization is elastic (``auto`` is)."""
    disc = base.get("discretization") or {}
    return not isinstance(disc, dict) or disc.get("formulation", "euler_bernoulli") != "rigid"


def modal_requested(config: dict) -> bool:
    """Whether the base scene asks for a modal analysis with an elastic formulation (the
    study then has natural frequencies and Campbell diagrams).

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    bool
    """
    base = config.get("base_scene") or {}
    return bool(base.get("modal")) and _elastic(base)


def estimate_requested(config: dict) -> bool:
    """Whether the study's cases carry an ``error_estimate``: an elastic formulation and
    ``outputs.error_estimate`` (default true) in the base scene.

    Parameters
    ----------
    config : dict
        A study configuration (its ``base_scene``).

    Returns
    -------
    bool
        True when the cases carry an error estimate.
    """
    base = config.get("base_scene") or {}
    return _elastic(base) and (base.get("outputs") or {}).get("error_estimate", True) is True



def axis_length(spec) -> int:
    """Number of values of one grid axis (:func:`grid_values`), without building them.

    Parameters
    ----------
    spec : list or dict
        A list of values or a range ``{start, stop, num}``.

    Returns
    -------
    int
        The number of values.
    """
    if isinstance(spec, Mapping):
        return int(spec["num"])
    return len(spec) if isinstance(spec, (list, tuple)) else 1


def grid_axes(config: dict) -> list[tuple[str, object]]:
    """(key path, spec) of every axis of the study's grid, in case-table order.

    Parameters
    ----------
    config : dict
        A validated study config (:func:`ced.study.config.validate_config`).

    Returns
    -------
    list of (str, object)
        Dotted key path (``grids.four_bar.crank``, ``speeds``, …) and the axis as written.
    """
    axes = []
    for kind, keys in GRID_KEYS.items():
        grid = config.get("grids", {}).get(kind)
        if grid:
            axes += [(f"grids.{kind}.{k}", grid.get(k, [0.0])) for k in keys]
    return axes + [("speeds", config["speeds"])]


def grid_points(config: dict) -> int:
    """Cases before the assembly check and the family filter: Σ over mechanism types of the
    product of their axis lengths, × speeds × materials × sections (nothing enumerated).

    Parameters
    ----------
    config : dict
        A study config (schema-valid).

    Returns
    -------
    int
        Grid points.
    """
    inner = axis_length(config["speeds"]) * len(config["materials"]) * len(config["sections"])
    total = 0
    for kind, keys in GRID_KEYS.items():
        grid = config.get("grids", {}).get(kind)
        if grid:
            total += math.prod(axis_length(grid.get(k, [0.0])) for k in keys)
    return total * inner
