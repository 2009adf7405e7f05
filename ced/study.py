"""Studies: the case table of a config, its chunks, and the job that simulates one chunk.

The case table is a pure, deterministic function of the config (DESIGN §6): the cartesian
product of the grids, each case classified (Grashof) into its family, filtered by the
families to keep, in a fixed order. Chunks are consecutive slices of a family's cases, so a
job is named by (family, chunk index) — never by a float.
"""
from __future__ import annotations

import copy
import itertools
import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .cases import case_family
from .errors import SceneError
from .mechanism import FAMILIES, assembly_error

__all__ = ["grid_values", "case_table", "chunks", "chunk_scenes", "run_chunk", "study_size"]

#: Length keys of the grids of each mechanism type.
GRID_KEYS = {
    "four_bar": ("crank", "coupler", "rocker"),
    "slider_crank": ("crank", "rod", "offset"),
}


def grid_values(spec, path: str) -> list[float]:
    """A grid axis from a list or {start, stop, num} (inclusive, evenly spaced)."""
    if isinstance(spec, Mapping):
        num = int(spec["num"])
        return [float(v) for v in np.linspace(spec["start"], spec["stop"], num)]
    if isinstance(spec, (list, tuple)):
        return [float(v) for v in spec]
    return [float(spec)]


def _scene_for(config: dict, kind: str, lengths: dict, speed: float, material: str,
               section: dict) -> dict:
    base = copy.deepcopy(config.get("base_scene", {}))
    mechanism = {"type": kind, **lengths}
    if kind == "slider_crank":
        mechanism["slider_mass"] = config["grids"]["slider_crank"].get("slider_mass", 0.0)
    base["mechanism"] = mechanism
    links = base.setdefault("links", {})
    default = links.setdefault("default", {})
    default["material"] = material
    default["section"] = dict(section)
    base.setdefault("drive", {})["speed"] = speed
    return base


def case_table(config: dict) -> list[dict]:
    """Every case of the study, in a deterministic order.

    Each row: ``family``, ``scene`` (an un-normalized scene dict), and the grid parameters
    (``mechanism``, lengths, ``speed``, ``material``, ``section`` index). Linkages that cannot
    be assembled are dropped, as are families not in ``config["families"]``.
    """
    keep = set(config.get("families", FAMILIES))
    speeds = grid_values(config["speeds"], "speeds")
    materials = list(config["materials"])
    sections = list(config["sections"])
    rows = []
    for kind in ("four_bar", "slider_crank"):
        grid = config.get("grids", {}).get(kind)
        if not grid:
            continue
        axes = [grid_values(grid[k], f"grids.{kind}.{k}") for k in GRID_KEYS[kind]]
        for values in itertools.product(*axes):
            lengths = dict(zip(GRID_KEYS[kind], values))
            if kind == "four_bar":
                lengths = {"ground": float(grid["ground"]), **lengths}
            if assembly_error({"type": kind, **lengths}):
                continue
            family = case_family({"mechanism": {"type": kind, **lengths}})
            if family not in keep:
                continue
            for speed, (m, material), (s, section) in itertools.product(
                    speeds, enumerate(materials), enumerate(sections)):
                rows.append({
                    "family": family, "mechanism": kind, **lengths, "speed": speed,
                    "material": material, "section": s,
                    "scene": _scene_for(config, kind, lengths, speed, material, section),
                })
    return rows


def study_size(config: dict) -> int:
    """Number of grid points before classification (for the up-front size check)."""
    n = len(grid_values(config["speeds"], "speeds")) * len(config["materials"]) * len(
        config["sections"])
    total = 0
    for kind, keys in GRID_KEYS.items():
        grid = config.get("grids", {}).get(kind)
        if grid:
            total += math.prod(len(grid_values(grid[k], k)) for k in keys)
    return total * n


def chunks(config: dict) -> dict[str, int]:
    """Number of chunks of each family present in the study."""
    size = int(config["chunk_size"])
    counts: dict[str, int] = {}
    for row in case_table(config):
        counts[row["family"]] = counts.get(row["family"], 0) + 1
    return {f: math.ceil(n / size) for f, n in counts.items()}


def chunk_scenes(config: dict, family: str, index: int) -> list[dict]:
    """Scenes of chunk ``index`` of ``family``."""
    size = int(config["chunk_size"])
    rows = [r for r in case_table(config) if r["family"] == family]
    part = rows[index * size : (index + 1) * size]
    if not part:
        raise SceneError("chunk", f"family {family!r} has no chunk {index}")
    return [r["scene"] for r in part]


def run_chunk(config: dict, family: str, index: int, output: str | Path) -> Path:
    """Simulate one chunk and write its dataset atomically."""
    from .io import write_dataset
    from .simulation import simulate

    ds = simulate(chunk_scenes(config, family, index))
    # Case ids unique within the family, so chunk files concatenate without clashes.
    ds = ds.assign_coords(case=ds.case + index * int(config["chunk_size"]))
    ds.attrs["study"] = str(config.get("study", "study"))
    ds.attrs["chunk"] = f"{family}/{index}"
    return write_dataset(ds, output)
