"""Study configs: read, validate against the schema and every check it cannot express,
and estimate the study's size before any work.

Bad input is refused up front: :func:`validate_config` (used by the Snakefile through
:func:`check_config` and by ``ced check``) applies the JSON schema and every check it cannot
express, and refuses studies whose estimated size (:class:`StudyEstimate`) is beyond
:data:`MAX_GRID_POINTS`, :data:`MAX_OUTPUT_BYTES` or the machine's memory. Its only error is
:class:`~ced.problem.errors.SceneError`, naming the config key (``grids.four_bar.crank[2]``).

Examples
--------
>>> config = {"study": "example",
...           "grids": {"four_bar": {"ground": 0.5, "crank": [0.1, 0.2],
...                                  "coupler": [0.45], "rocker": [0.35]}},
...           "speeds": [50.0, 100.0], "materials": ["steel"],
...           "sections": [{"shape": "rectangle", "height": 0.005, "width": 0.01}],
...           "chunk_size": 3}
>>> estimate = study_estimate(config)
>>> estimate.cases, estimate.chunks
(4, {'crank_rocker': 2})
>>> validate_config({**config, "speeds": [50.0, -1.0]})
Traceback (most recent call last):
...
ced.problem.errors.SceneError: speeds[1]: must be > 0, got -1.0
"""
from __future__ import annotations

import copy
import dataclasses
import math
import re
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from ..problem.errors import SceneError, join, key_path, shown
from ..problem.mechanism import assembly_error
from ..problem.scene import load_scene
from ..problem.yaml_files import check_structure, load_yaml
from ..simulation.size import case_bytes, case_seconds, machine_memory, run_memory, size_text
from .cases import (FIXED_KEYS, GRID_KEYS, axis_length, case_row, drive_amplitude, family_kept,
                    grid_axes, grid_geometries, grid_points, grid_values, inner_points,
                    material_names, scene_for, split_geometries)
from .convergence import load_sweep

__all__ = [
    "load_config",
    "apply_schema",
    "validate_config",
    "study_estimate",
    "check_config",
    "StudyEstimate",
    "MAX_GRID_POINTS",
    "MAX_OUTPUT_BYTES",
    "SCHEMA_PATH",
    "JOB_SECONDS",
    "CHUNK_START_SECONDS",
    "LADDER_SECONDS",
]

#: Largest study accepted: grid points (cases before the assembly check and the family filter;
#: counted without enumerating them). Classifying a geometry takes about 14 µs, so beyond this
#: the parse-time case table alone takes minutes.
MAX_GRID_POINTS = 10_000_000
#: Largest estimated output accepted (uncompressed netCDF variables of every chunk), bytes.
MAX_OUTPUT_BYTES = 10 * 10**12
#: Fixed cost of one Snakemake job, s: interpreter start, imports of numpy, xarray and ced,
#: reading and writing. Measured on config/studies/test.yaml (2026-11-24, 2 cores under load):
#: its figure and reduction jobs took 4-6 s, its chunk jobs 4.4-5.5 s of which 1.6-2.1 s in
#: the first solve of 4 tiny cases (lazy imports, caches: CHUNK_START_SECONDS).
#: benchmarks/estimate_check.py compares the whole estimate with a measured run.
JOB_SECONDS = 4.5
#: A chunk job's first solve beyond its cases' cost (lazy imports, caches), s.
CHUNK_START_SECONDS = 1.0
#: The fidelity ladder's job beyond JOB_SECONDS, s (one scene through every model).
LADDER_SECONDS = 6.0
#: The JSON schema of study configs (applied by :func:`validate_config`).
SCHEMA_PATH = Path(__file__).resolve().parents[2] / "workflow" / "schemas" / "config.schema.yaml"

_TYPE_WORDS = {"number": "a number", "integer": "an integer", "string": "a string",
               "array": "a list", "object": "a mapping", "boolean": "true or false",
               "null": "null"}


def load_config(path: str | Path) -> dict:
    """Read a study config file as Snakemake does (YAML 1.1, or JSON), through the YAML reader
    scenes use too (:func:`ced.problem.yaml_files.load_yaml`: its size, nesting and alias
    limits, duplicate keys refused).

    Raises :class:`SceneError` at ``<config>`` for a file that cannot be read or parsed or
    whose top level is not a mapping.

    Parameters
    ----------
    path : str or Path
        The config file.

    Returns
    -------
    dict
        The config as read (not yet validated: :func:`validate_config`).
    """
    config = load_yaml(path, "<config>", "1.1")
    if not isinstance(config, dict):
        raise SceneError("<config>", f"the top level must be a mapping, got {shown(config)}")
    return config


def _schema() -> dict:
    import yaml

    if not SCHEMA_PATH.exists():
        raise FileNotFoundError(f"config schema not found at {SCHEMA_PATH} (ced must be "
                                f"installed from its repository, e.g. pip install -e .)")
    return yaml.safe_load(SCHEMA_PATH.read_text(encoding="utf-8"))


def _path(parts) -> str:
    """Dotted key path of a JSON-schema error location (``grids.four_bar.crank[2]``)."""
    path = ""
    for part in parts:
        path = f"{path}[{part}]" if isinstance(part, int) else key_path(path, part)
    return path or "<config>"


def _with_hint(err: SceneError) -> SceneError:
    """Add a hint to an error about a number written so that YAML 1.1 reads a string.

    Snakemake reads config files with PyYAML (YAML 1.1), where ``1e-3`` and ``2.1e11`` (no
    dot, or no sign in the exponent) are strings; ``1.0e-3`` and ``2.1e+11`` are numbers.
    """
    match = re.search(r"got '([^']*)'$", err.message)
    if match:
        try:
            float(match.group(1))
        except ValueError:
            return err
        return SceneError(err.path, err.message + " (a string, not a number: Snakemake reads "
                                                  "config files as YAML 1.1, where exponent "
                                                  "form needs a dot and a signed exponent, "
                                                  "e.g. 1.0e-3, 2.1e+11)")
    return err


def _schema_error(err) -> SceneError:
    """A :class:`SceneError` (key path + plain message) for one ``jsonschema`` error."""
    from jsonschema.exceptions import best_match

    if err.parent is not None and err.parent.validator == "anyOf":
        err = err.parent  # a name from a list or of a pattern: report against both
    kind, rule, value = err.validator, err.validator_value, err.instance
    path = _path(err.absolute_path)
    got = f"got {shown(value)}"
    if kind == "oneOf":
        branches = [sub.get("type") for sub in rule]
        # Report inside the branch whose type the value has (e.g. a range missing "num").
        fitting = [i for i, sub in enumerate(rule)
                   if not any(e.validator == "type" and list(e.relative_schema_path)[:2]
                              == [i, "type"] for e in err.context)]
        if len(fitting) == 1:
            errors = [e for e in err.context if e.relative_schema_path[0] == fitting[0]]
            missing = [e for e in errors if e.validator == "required"]
            if missing and len(missing) == len(errors):
                names = [k for k in missing[0].validator_value if k not in value]
                return SceneError(path, f"missing {join(names)}; required: "
                                        f"{join(missing[0].validator_value)}")
            return _schema_error(best_match(errors))
        words = " or ".join(_TYPE_WORDS.get(t, str(t)) for t in branches)
        return SceneError(path, f"must be {words}, {got}")
    if kind == "anyOf" and any("enum" in sub for sub in rule):
        # A name from a list or of a pattern (families): list both, not the pattern itself.
        named = [v for sub in rule for v in sub.get("enum", [])]
        named += [sub["description"] for sub in rule if "pattern" in sub]
        return SceneError(path, f"unknown value {shown(value)}; allowed: {join(named)}")
    if kind == "additionalProperties":
        allowed = list(err.schema.get("properties", {}))
        extra = next(k for k in value if k not in allowed)
        return SceneError(key_path(path.replace("<config>", ""), extra),
                          f"unknown key {shown(extra)}; allowed: {join(allowed)}")
    if kind == "required":
        missing = [k for k in rule if k not in value]
        return SceneError(key_path(path.replace("<config>", ""), missing[0]),
                          f"missing; required keys here: {join(rule)}")
    words = {
        "type": lambda: f"must be {_TYPE_WORDS.get(rule, str(rule))}, {got}",
        "enum": lambda: f"unknown value {shown(value)}; allowed: {join(rule)}",
        "exclusiveMinimum": lambda: f"must be > {rule:g}, {got}",
        "minimum": lambda: f"must be >= {rule:g}, {got}",
        "maximum": lambda: f"must be <= {rule:g}, {got}",
        "exclusiveMaximum": lambda: f"must be < {rule:g}, {got}",
        "minItems": lambda: "must not be empty" if rule == 1 else f"needs {rule} items, {got}",
        "minProperties": lambda: f"must not be empty; give one of: "
                                 f"{join(err.schema.get('properties', {}))}",
        "uniqueItems": lambda: f"must not repeat a value, {got}",
        "pattern": lambda: f"must match {rule}, {got}",
    }
    return _with_hint(SceneError(path, words[kind]() if kind in words else err.message))


def apply_schema(config: Mapping) -> dict:
    """A copy of ``config`` checked against :data:`SCHEMA_PATH`, schema defaults filled in.

    Defaults are set while validating (as ``snakemake.utils.validate`` does), so a default
    inside an optional block (``grids.slider_crank.offset``) appears only with the block.
    The first error (``jsonschema``'s best match) becomes a :class:`SceneError`.

    Parameters
    ----------
    config : mapping
        A study config.

    Returns
    -------
    dict
        A checked copy with defaults filled in.
    """
    from jsonschema import Draft202012Validator, validators
    from jsonschema.exceptions import best_match

    def set_defaults(validator, properties, instance, schema):
        if isinstance(instance, dict):
            for name, sub in properties.items():
                if "default" in sub:
                    instance.setdefault(name, copy.deepcopy(sub["default"]))
        yield from Draft202012Validator.VALIDATORS["properties"](
            validator, properties, instance, schema)

    checker = validators.extend(Draft202012Validator, {"properties": set_defaults})(_schema())
    filled = copy.deepcopy(dict(config))
    error = best_match(checker.iter_errors(filled))
    if error is not None:
        raise _schema_error(error)
    return filled


def _check_base_blocks(config: dict) -> None:
    """The base scene's blocks that the case table fills in (``mechanism``, ``links`` and its
    ``default``, ``drive``) are mappings, or null for the scene's defaults; the rest of the
    base scene is checked as a scene (:func:`_check_scenes`)."""
    base = config.get("base_scene") or {}
    blocks = {key: base.get(key) for key in ("mechanism", "links", "drive")}
    if isinstance(blocks["links"], Mapping):
        blocks["links.default"] = blocks["links"].get("default")
    for key, value in blocks.items():
        if value is not None and not isinstance(value, Mapping):
            raise SceneError(f"base_scene.{key}", "must be a mapping of its keys (or null for "
                                                  f"the scene's defaults); got {shown(value)}")


def _check_finite(value, path: str) -> None:
    """Refuse NaN and ±inf anywhere in ``value`` (``base_scene`` is left to ced.problem.scene)."""
    if isinstance(value, float) and not math.isfinite(value):
        raise SceneError(path, f"must be a finite number, got {shown(value)}")
    if isinstance(value, Mapping):
        for key, item in value.items():
            if not (path == "<config>" and key == "base_scene"):
                _check_finite(item, key_path("" if path == "<config>" else path, key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _check_finite(item, f"{path}[{i}]")


@dataclass(frozen=True)
class StudyEstimate:
    """Size of a validated study (see :func:`case_bytes` for the per-case formula).

    Attributes
    ----------
    grid_points : int
        Cases before the assembly check and the family filter.
    cases : int
        Cases simulated.
    chunks : dict of str to int
        Chunk jobs of each family.
    output_bytes : int
        Σ over cases of :func:`case_bytes` (float32 station fields), uncompressed.
    largest_chunk : int
        Cases of the largest chunk job (``chunk_size`` or the size of the largest family).
    chunk_memory_bytes : int
        Estimated peak memory of the largest chunk job:
        :func:`ced.simulation.size.run_memory` of its cases (the same estimate ``ced run`` and
        ``ced.simulate`` apply before any work).
    case_seconds : dict of str to float
        Estimated solve time of one case of each family, s
        (:func:`ced.simulation.size.case_seconds` of the family's representative scene).
    family_cases : dict of str to int
        Cases of each family.
    other_jobs : int
        Snakemake jobs besides the chunks: per family its reduction, resonance map and
        worst-case figure (and Campbell diagram with a modal analysis), and the study's
        overview, safe-speed table and fidelity ladder.
    not_assemblable : dict of str to int
        Grid geometries of each mechanism type dropped because they cannot be assembled over
        the whole input motion (types with none are left out).
    """

    grid_points: int
    cases: int
    chunks: dict
    output_bytes: int
    largest_chunk: int
    chunk_memory_bytes: int
    case_seconds: dict = dataclasses.field(default_factory=dict)
    other_jobs: int = 0
    family_cases: dict = dataclasses.field(default_factory=dict)
    not_assemblable: dict = dataclasses.field(default_factory=dict)

    def run_seconds(self, cores: int) -> float:
        """Estimated wall time of the whole pipeline on ``cores`` cores, s.

        Every job costs :data:`JOB_SECONDS` (interpreter, imports, writing) plus, for a chunk,
        :data:`CHUNK_START_SECONDS` and its cases' solve time; the fidelity ladder
        :data:`LADDER_SECONDS` more. Jobs share the
        cores: the estimate is the total over the cores, but never less than the longest job.
        Not counted: the optional convergence study.
        """
        chunk_jobs = [JOB_SECONDS + CHUNK_START_SECONDS + self.family_cases.get(f, 0) / n
                      * self.case_seconds.get(f, 0.0)
                      for f, n in self.chunks.items() for _ in range(n)]
        other = [JOB_SECONDS] * max(self.other_jobs - 1, 0) + [JOB_SECONDS + LADDER_SECONDS]
        jobs = chunk_jobs + other
        return max(sum(jobs) / max(int(cores), 1), max(jobs))

    def summary(self) -> str:
        jobs = sum(self.chunks.values())
        per_family = ", ".join(f"{f} {n}" for f, n in self.chunks.items())
        dropped = "".join(f"; {n} {kind} geometries not assemblable, dropped"
                          for kind, n in self.not_assemblable.items())
        return (f"{self.cases} cases ({self.grid_points} grid points before the assembly "
                f"check and family filter{dropped}) in {jobs} chunk jobs ({per_family}); "
                f"estimated "
                f"output {size_text(self.output_bytes)} uncompressed; estimated peak memory per "
                f"chunk job {size_text(self.chunk_memory_bytes)}")


def _scene_error(err: SceneError, kind: str, material: int, section: int) -> SceneError:
    """Re-home an error in a case's scene to the config key that wrote the value."""
    err = _with_hint(err)
    path = err.path
    moves = {"links.default.material": f"materials[{material}]",
             "links.default.section": f"sections[{section}]", "drive.speed": "speeds"}
    for prefix, target in moves.items():
        if path == prefix or path.startswith(prefix + ".") or path.startswith(prefix + "["):
            return SceneError(target + path[len(prefix):], err.message)
    if path.startswith("mechanism.") and (path.split(".")[1]
                                          in GRID_KEYS[kind] + FIXED_KEYS[kind]):
        return SceneError(f"grids.{kind}.{path.split('.')[1]}", err.message)
    if path == "<scene>":
        return SceneError("base_scene", err.message)
    return SceneError(f"base_scene.{path}", err.message)


def _check_scenes(config: dict, geometries: list) -> dict[str, dict]:
    """Load one scene per (family, material) and per (family, section) kept; return a
    normalized scene of each mechanism type."""
    names = material_names(config)
    first = {}
    for kind, family, lengths in geometries:
        first.setdefault(family, (kind, lengths))
    speed = grid_values(config["speeds"], "speeds")[0]
    normalized = {}
    for family, (kind, lengths) in first.items():
        pairs = [(m, 0) for m in range(len(names))] + [
            (0, s) for s in range(1, len(config["sections"]))]
        for m, s in pairs:
            row = case_row(config, kind, family, lengths, 0, (speed, m, s), names, True)
            try:
                normalized.setdefault(kind, load_scene(row["scene"]))
            except SceneError as err:
                raise _scene_error(err, kind, m, s) from None
    return normalized


def _check_axes(config: dict) -> None:
    """Every axis well formed with distinct values (they label the grid maps' dimensions)."""
    for path, spec in grid_axes(config):
        values = grid_values(spec, path)
        repeated = sorted(v for v, n in Counter(values).items() if n > 1)
        if repeated:
            raise SceneError(path, f"values must be distinct, repeated: {join(repeated)}")


def _check_map_slice(config: dict) -> None:
    """``resonance_map.fixed`` values must be grid values of their length in some family."""
    for key, value in (config.get("resonance_map", {}).get("fixed") or {}).items():
        values = sorted({v for grid in config["grids"].values() if key in grid
                         for v in grid_values(grid[key], f"grids.*.{key}")})
        if not any(math.isclose(value, v, rel_tol=1e-9, abs_tol=1e-12) for v in values):
            allowed = ", ".join(f"{v:g}" for v in values) or f"none: no grid has {key}"
            raise SceneError(f"resonance_map.fixed.{key}",
                             f"{value!r} m is not a grid value of {key}; allowed: {allowed}")


def _check_families(config: dict, geometries: list) -> None:
    """Every mechanism type of the grids has an assemblable geometry, and a kept family has
    a case."""
    for kind in GRID_KEYS:
        grid = config["grids"].get(kind)
        if grid and not any(g[0] == kind for g in geometries):
            lengths, mechanism = next(grid_geometries(config, kind))
            example = ", ".join(f"{k} {v:g}" for k, v in lengths.items())
            reason = assembly_error(mechanism, drive_amplitude(config))
            raise SceneError(f"grids.{kind}", f"no geometry of the grid can be assembled, "
                                              f"e.g. {example}: {reason}")
    produced = {}
    for _, family, _ in geometries:
        produced[family] = produced.get(family, 0) + 1
    keep = config["families"]
    if not any(family_kept(config, g[0], g[1]) for g in geometries):
        made = ", ".join(f"{f} ({n} geometries)" for f, n in produced.items())
        raise SceneError("families", f"the grids give no case of the families asked for "
                                     f"({join(keep)}); they produce: {made}")


def _estimate(config: dict, geometries: list, scenes: dict[str, dict],
              refused: dict[str, int]) -> StudyEstimate:
    size = int(config["chunk_size"])
    inner = len(inner_points(config))
    sizes: dict[str, int] = {}
    kinds: dict[str, str] = {}
    for kind, family, _ in geometries:
        if family_kept(config, kind, family):
            sizes[family] = sizes.get(family, 0) + inner
            kinds[family] = kind
    output = sum(n * case_bytes(scenes[kinds[f]]) for f, n in sizes.items())
    memory, largest = max((run_memory([scenes[kinds[f]]] * min(n, size))[0], min(n, size))
                          for f, n in sizes.items())
    modal = any(scenes[kinds[f]].get("modal") for f in sizes)
    return StudyEstimate(
        grid_points=grid_points(config), cases=sum(sizes.values()),
        chunks={f: math.ceil(n / size) for f, n in sizes.items()}, output_bytes=output,
        largest_chunk=largest, chunk_memory_bytes=memory,
        case_seconds={f: case_seconds(scenes[kinds[f]]) for f in sizes},
        other_jobs=len(sizes) * (4 if modal else 3) + 3, family_cases=dict(sizes),
        not_assemblable=dict(refused))


#: A linkage of each mechanism type that can be assembled, to size a case before the grid is
#: built (the sizes of :func:`case_bytes` do not depend on the lengths).
_STAND_IN = {"four_bar": {"ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35},
             "slider_crank": {"crank": 0.15, "rod": 0.3, "offset": 0.0},
             "watt_ii": {"ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35,
                         "rocker_arm": 0.25, "rocker_arm_angle": 2.5, "coupler2": 0.4,
                         "rocker2": 0.3, "pivot2_x": 0.2, "pivot2_y": -0.3},
             "stephenson_iii": {"ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35,
                                "coupler_arm": 0.3, "coupler_arm_angle": 0.6, "coupler2": 0.4,
                                "rocker2": 0.3, "pivot2_x": 0.4, "pivot2_y": 0.55}}


def _upper_bounds(config: dict) -> str:
    """``; at most … output, … per chunk job`` from the grid points and the base scene, or
    ``""`` if the base scene is itself invalid (reported once the study is small enough)."""
    output, memory = 0, 0
    inner = axis_length(config["speeds"]) * len(config["materials"]) * len(config["sections"])
    for kind, keys in GRID_KEYS.items():
        grid = config["grids"].get(kind)
        if not grid:
            continue
        scene = scene_for(config, kind, _STAND_IN[kind], 1.0, config["materials"][0],
                           config["sections"][0])
        try:
            scene = load_scene(scene)
        except SceneError:
            return ""
        output += inner * math.prod(axis_length(grid.get(k, [0.0])) for k in keys) \
            * case_bytes(scene)
        chunk = min(config["chunk_size"], grid_points(config))
        memory = max(memory, run_memory([scene] * chunk)[0])
    return (f"; estimated output at most {size_text(output)} uncompressed, peak memory per chunk "
            f"job about {size_text(memory)}")


def _largest_axis(config: dict) -> str:
    return max(grid_axes(config), key=lambda a: axis_length(a[1]))[0]


def _validated(config: Mapping, memory: int | None = None) -> tuple[dict, StudyEstimate]:
    check_structure(config, "<config>")  # before anything walks it: alias bombs, deep nesting
    config = apply_schema(config)
    _check_finite(config, "<config>")
    _check_base_blocks(config)
    load_sweep(config, root=SCHEMA_PATH.parents[2])  # the Snakefile reads it at parse time
    points = grid_points(config)
    if points > MAX_GRID_POINTS:
        # Refused before any value is built: bounds on cases, output and memory are enough.
        raise SceneError(_largest_axis(config), (
            f"the study has {points:.4g} grid points (cases before the assembly check and "
            f"family filter), more than the limit of {MAX_GRID_POINTS:.4g}; axis lengths: "
            + ", ".join(f"{p} {axis_length(s)}" for p, s in grid_axes(config))
            + f", materials {len(config['materials'])}, sections {len(config['sections'])}"
            + _upper_bounds(config)))
    _check_axes(config)
    _check_map_slice(config)
    try:
        names = material_names(config)
    except SceneError as err:
        raise _with_hint(err) from None
    repeated = sorted(n for n, count in Counter(names).items() if count > 1)
    if repeated:
        raise SceneError("materials", f"material names must be distinct, repeated: "
                                      f"{join(repeated)}")
    geometries, refused = split_geometries(config)
    _check_families(config, geometries)
    kept = [g for g in geometries if family_kept(config, g[0], g[1])]
    scenes = _check_scenes(config, kept)
    estimate = _estimate(config, kept, scenes, refused)
    if estimate.output_bytes > MAX_OUTPUT_BYTES:
        raise SceneError("grids", f"estimated output {size_text(estimate.output_bytes)} exceeds the "
                                  f"limit of {size_text(MAX_OUTPUT_BYTES)}: {estimate.summary()}")
    memory = machine_memory() if memory is None else memory
    for scene in scenes.values():  # one case too large: the base scene is to blame
        need, key = run_memory([scene])
        if need > memory:
            raise SceneError(f"base_scene.{key}", (
                f"one case needs about {size_text(need)} of memory, more than the "
                f"{size_text(memory)} of this machine, whatever the chunk_size"))
    if estimate.chunk_memory_bytes > memory:
        raise SceneError("chunk_size", (
            f"a chunk of {estimate.largest_chunk} cases needs about "
            f"{size_text(estimate.chunk_memory_bytes)} of memory, more than the "
            f"{size_text(memory)} of this machine; use a smaller chunk_size ({estimate.summary()})"))
    return config, estimate


def validate_config(config: Mapping, *, memory: int | None = None) -> dict:
    """Check a study config completely and return a copy with the schema defaults filled in.

    In order: size and nesting (:func:`ced.problem.yaml_files.check_structure`); the JSON
    schema (:func:`apply_schema`: types, ranges, unknown keys, families); finite numbers; the study size (:data:`MAX_GRID_POINTS`, counted without building the
    grid); distinct grid values and material names; at least one assemblable geometry for
    each mechanism type of ``grids`` and a case for the families asked for; one scene per
    (family, material) and (family, section) through :func:`ced.problem.scene.load_scene`
    (errors are reported at the config key that wrote the value: ``materials[1].nu``,
    ``sections[0].height``, ``base_scene.time.start``); the estimated output
    (:data:`MAX_OUTPUT_BYTES`) and the peak memory of a chunk job (``memory``, bytes; default
    this machine's, :func:`machine_memory`). See :class:`StudyEstimate` for the estimates.

    Parameters
    ----------
    config : mapping
        A study config.
    memory : int, optional
        Memory a chunk job may use, bytes (default: this machine's).

    Returns
    -------
    dict
        A validated copy with the schema defaults filled in.

    Raises
    ------
    SceneError
        The only error for bad input: ``err.path`` is the key path (``grids.four_bar.crank[2]``,
        ``speeds``, ``<config>`` for the document), ``err.message`` what is allowed.
    """
    return _validated(config, memory)[0]


def study_estimate(config: Mapping, *, memory: int | None = None) -> StudyEstimate:
    """Validate ``config`` (:func:`validate_config`) and return its :class:`StudyEstimate`.

    Parameters
    ----------
    config : mapping
        A study config.
    memory : int, optional
        Memory a chunk job may use, bytes (default: this machine's).

    Returns
    -------
    StudyEstimate
        Cases, chunk jobs, output bytes, memory per chunk job and run-time model.
    """
    return _validated(config, memory)[1]


def check_config(config: dict) -> dict[str, int]:
    """Validate ``config`` in place for the Snakefile (defaults filled, as
    ``snakemake.utils.validate`` does) and return :func:`chunks`.

    Everything :func:`validate_config` checks fails here, at parse time, before any job.

    Parameters
    ----------
    config : dict
        The config Snakemake read; replaced in place by the validated one.

    Returns
    -------
    dict of str to int
        Chunk jobs per family.
    """
    filled, estimate = _validated(config)
    config.clear()
    config.update(filled)
    return dict(estimate.chunks)
