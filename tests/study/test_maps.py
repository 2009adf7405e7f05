"""Reductions (docs/guide/first_study.md): per-case peaks of a family and the same unstacked onto the grid."""
import copy
import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from snakemake.utils import validate

import ced.study.cases
from ced.problem.status import STATUS_DTYPE, STATUS_FILL, STATUS_FLAGS
from ced.study.maps import case_summary, family_grid, reduce_family
from ced.study.cases import case_table, chunks
from ced.study.chunk_job import run_chunk
from ced.io import open_dataset

ROOT = Path(__file__).resolve().parents[2]


def cf_problems(ds: xr.Dataset) -> list[str]:
    """Variables without long_name, or numeric ones without units (CF conventions)."""
    problems = []
    for name, var in ds.variables.items():
        if "long_name" not in var.attrs:
            problems.append(f"{name}: no long_name")
        if var.dtype.kind in "fiu" and "units" not in var.attrs:
            problems.append(f"{name}: no units")
    for key in ("Conventions", "title", "institution", "source", "history", "references"):
        if key not in ds.attrs:
            problems.append(f"global attribute {key} missing")
    return problems


# ------------------------------------------------------------------------------ synthetic
def synthetic(n_links=2) -> xr.Dataset:
    """A per-case summary over a 2 x 2 x 2 (crank, speed, material) grid minus one point."""
    crank, speed, material = np.meshgrid([0.1, 0.2], [50.0, 100.0], ["steel", "brass"],
                                         indexing="ij")
    keep = np.ones(crank.shape, bool)
    keep[1, 1, 0] = False  # (0.2, 100, steel) is not in this family
    n = int(keep.sum())
    case = np.arange(n) + 10
    coords = {
        "case": ("case", case, {"long_name": "case id within the family"}),
        "crank": ("case", crank[keep], {"units": "m", "long_name": "crank"}),
        "coupler": ("case", np.full(n, 0.4), {"units": "m", "long_name": "coupler"}),
        "speed": ("case", speed[keep], {"units": "rad s-1", "long_name": "input speed"}),
        "material": ("case", material[keep].astype(object), {"long_name": "material"}),
        "section": ("case", np.zeros(n, "int32"), {"units": "1", "long_name": "section"}),
        "section_height": ("case", np.full(n, 0.02), {"units": "m", "long_name": "height"}),
        "family": ("case", np.array(["crank_rocker"] * n, object), {"long_name": "family"}),
        "link": ("link", np.array(["crank", "coupler"][:n_links], object),
                 {"long_name": "link"}),
    }
    torque = np.arange(n, dtype=float) + 1.0
    status = np.zeros(n, STATUS_DTYPE)
    status[2] = STATUS_FLAGS["resonant"]
    ds = xr.Dataset(
        {"peak_input_torque": ("case", torque, {"units": "N m", "long_name": "torque"}),
         "peak_stress": (("case", "link"), np.outer(torque, [1.0, 2.0][:n_links]),
                         {"units": "Pa", "long_name": "peak stress"}),
         "status": ("case", status, {"units": "1", "long_name": "case status flags",
                                     "flag_masks": np.array(list(STATUS_FLAGS.values()),
                                                            STATUS_DTYPE),
                                     "flag_meanings": " ".join(STATUS_FLAGS)}),
         "message": ("case", np.array([""] * n, object), {"long_name": "diagnostic message"})},
        coords=coords)
    ds.attrs.update(Conventions="CF-1.12", title="t", institution="i", source="s",
                    history="h", references="r")
    return ds


def test_family_grid_unstacks_cases():
    summary = synthetic()
    grid = family_grid(summary)
    # every grid axis is a dimension, even with one value: the same layout in every study
    assert grid.peak_input_torque.dims == ("crank", "coupler", "speed", "material", "section")
    assert list(grid.crank.values) == [0.1, 0.2] and list(grid.coupler.values) == [0.4]
    assert sorted(grid.material.values.tolist()) == ["brass", "steel"]
    for i in range(summary.sizes["case"]):
        row = summary.isel(case=i)
        at = dict(crank=row.crank.item(), coupler=0.4, speed=row.speed.item(),
                  material=row.material.item(), section=row.section.item())
        assert grid.peak_input_torque.sel(at).item() == row.peak_input_torque.item()
        assert grid.peak_stress.sel(at).values.tolist() == row.peak_stress.values.tolist()
        assert grid.status.sel(at).item() == row.status.item()
        assert grid["case"].sel(at).item() == row.case.item()
    missing = dict(crank=0.2, coupler=0.4, speed=100.0, material="steel", section=0)
    assert np.isnan(grid.peak_input_torque.sel(missing).item())
    assert grid.status.sel(missing).item() == STATUS_FILL
    assert grid["case"].sel(missing).item() == -1
    # other constant case coordinates become scalars; the section sizes live on `section`
    assert grid.family.dims == () and grid.family.item() == "crank_rocker"
    assert grid.section_height.dims == ("section",)
    assert "message" not in grid  # strings are per case only
    assert grid.crank.attrs["units"] == "m"


def test_family_grid_round_trips_through_netcdf(tmp_path):
    from ced.io import write_dataset

    grid = family_grid(synthetic())
    path = write_dataset(grid, tmp_path / "grid.nc")
    with open_dataset(path) as back:
        assert not cf_problems(back)
        missing = dict(crank=0.2, coupler=0.4, speed=100.0, material="steel", section=0)
        assert np.isnan(back.status.sel(missing).item())  # _FillValue decodes to NaN
        assert np.isnan(back["case"].sel(missing).item())
        assert back.status.sel(crank=0.1, coupler=0.4, speed=50.0, material="steel",
                               section=0).item() == 0
    with open_dataset(path, mask_and_scale=False) as raw:
        assert raw.status.dtype == STATUS_DTYPE
        assert raw.status.attrs["_FillValue"] == STATUS_FILL


def test_family_grid_rejects_repeated_grid_points():
    ds = synthetic()
    ds = ds.assign_coords(crank=("case", np.full(ds.sizes["case"], 0.1), ds.crank.attrs))
    with pytest.raises(ValueError, match="not unique"):
        family_grid(ds)


# ------------------------------------------------------------------------------ real chunks
@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """The test study's crank_rocker family, simulated in two chunks."""
    config = yaml.safe_load((ROOT / "config" / "studies" / "test.yaml").read_text())
    validate(config, str(ROOT / "workflow" / "schemas" / "config.schema.yaml"))
    directory = tmp_path_factory.mktemp("reduce")
    n = chunks(config)["crank_rocker"]
    assert n == 2
    paths = [run_chunk(config, "crank_rocker", i, directory / f"{i}.nc") for i in range(n)]
    reduce_family(list(reversed(paths)), directory / "map.nc", directory / "grid.nc",
                  stress_safety_factor=2.0)
    return config, directory, paths


def test_chunks_carry_family_case_ids(study):
    config, _, paths = study
    size = config["chunk_size"]
    for i, path in enumerate(paths):
        with open_dataset(path) as ds:
            assert ds.case.values.tolist() == list(range(i * size, (i + 1) * size))
            assert ds.attrs["chunk"] == f"crank_rocker/{i}"
            assert ds.section.values.tolist() == [0] * size
            scenes = json.loads(ds.attrs["scenes"])
            rows = case_table(config, "crank_rocker")[i * size:(i + 1) * size]
            assert [s["drive"]["speed"] for s in scenes] == [r["speed"] for r in rows]


def test_reduced_family(study):
    config, directory, paths = study
    rows = case_table(config, "crank_rocker", scenes=False)
    with open_dataset(directory / "map.nc") as ds:
        assert not cf_problems(ds)
        assert ds.case.values.tolist() == [r["case"] for r in rows]  # sorted back
        assert ds.speed.values.tolist() == [r["speed"] for r in rows]
        assert ds.material.values.tolist() == [r["material"] for r in rows]
        for name in ("peak_input_torque", "peak_joint_force", "peak_stress", "status",
                     "natural_frequency_min", "natural_frequency_max", "stress_utilisation"):
            assert name in ds, name
        assert (ds.natural_frequency_min <= ds.natural_frequency_max).all()
        yield_strength = {"steel": 235e6, "aluminium": None}
        for i in range(ds.sizes["case"]):
            y = yield_strength.get(str(ds.material.values[i]))
            if y:
                expect = 2.0 * ds.peak_stress.isel(case=i) / y
                np.testing.assert_allclose(ds.stress_utilisation.isel(case=i), expect)
        with open_dataset(paths[0]) as chunk:
            first = chunk.isel(case=0)
            np.testing.assert_allclose(ds.peak_input_torque.isel(case=0),
                                       abs(first.input_torque).max())
            np.testing.assert_allclose(ds.natural_frequency_min.isel(case=0),
                                       first.natural_frequency.min("modal_angle"))


def test_reduced_grid(study):
    config, directory, _ = study
    with open_dataset(directory / "grid.nc") as grid, \
            open_dataset(directory / "map.nc") as cases:
        assert not cf_problems(grid)
        assert grid.attrs["grid_dimensions"] == "crank coupler rocker speed material section"
        assert dict(grid.peak_input_torque.sizes) == {  # crank_rocker points of the grid only
            "crank": 1, "coupler": 1, "rocker": 2, "speed": 2, "material": 2, "section": 1}
        assert float(grid.ground) == 0.25 and grid.ground.attrs["units"] == "m"
        assert int(np.isfinite(grid["case"]).sum()) == cases.sizes["case"]
        for i in range(cases.sizes["case"]):
            c = cases.isel(case=i)
            at = dict(crank=c.crank.item(), coupler=c.coupler.item(), rocker=c.rocker.item(),
                      speed=c.speed.item(), material=c.material.item(), section=c.section.item())
            assert grid["case"].sel(at).item() == c.case.item()
            np.testing.assert_array_equal(grid.peak_stress.sel(at), c.peak_stress)


def test_case_summary_without_elastic_variables():
    config = yaml.safe_load((ROOT / "config" / "studies" / "test.yaml").read_text())
    config["base_scene"] = {"discretization": {"formulation": "rigid"},
                            "time": {"revolutions": 1, "steps_per_revolution": 16}}
    config["chunk_size"] = 250
    from ced.simulation.simulate import simulate

    ds = simulate(ced.study.cases.chunk_scenes(config, "slider_crank", 0))
    summary = case_summary(copy.deepcopy(ds), stress_safety_factor=2.0)
    assert "peak_input_torque" in summary and "peak_stress" not in summary
    assert "stress_utilisation" not in summary and "natural_frequency_min" not in summary
    grid = family_grid(summary)
    assert grid.attrs["grid_dimensions"] == "crank rod offset speed material"  # no section
    assert float(grid.slider_mass) == 0.05


# ------------------------------------------------------------------------------ harmonics, stability
def test_harmonic_ratio_hand_made():
    from ced.study.maps import harmonic_ratio

    speed = xr.DataArray([2 * np.pi * 10.0, 2 * np.pi * 10.0, 2 * np.pi * 3.0], dims="case")
    # case 0: band 12.0-12.5 Hz, harmonics 10, 20 Hz -> nearest edge 12.0 vs 10: 0.2;
    #         mode 2 band 31-31.5 vs 30: 0.0333 -> min 1/30
    # case 1: mode 1 band 19-21 contains 20 Hz -> 0
    # case 2: Ω/2π = 3 Hz, K = 20 -> harmonics up to 60 Hz; band 61-62 Hz -> 61/60 - 1
    low = xr.DataArray([[12.0, 31.0], [19.0, 55.0], [61.0, 70.0]], dims=("case", "mode"))
    high = xr.DataArray([[12.5, 31.5], [21.0, 56.0], [62.0, 71.0]], dims=("case", "mode"))
    ratio = harmonic_ratio(low, high, speed)
    np.testing.assert_allclose(ratio, [1 / 30, 0.0, 61 / 60 - 1], rtol=1e-6)
    assert ratio.attrs["units"] == "1" and "long_name" in ratio.attrs
    # with K = 2 the 60 Hz harmonic is out of reach: nearest is 6 Hz
    np.testing.assert_allclose(harmonic_ratio(low, high, speed, harmonics=2)[2],
                               61 / 6 - 1, rtol=1e-6)


def test_stable_flag():
    from ced.study.maps import stable_flag

    floquet = xr.DataArray([0.5, 1.2, np.nan, 0.9, 0.9], dims="case")
    status = xr.DataArray(np.array([0, 8, 16, 8, 0], STATUS_DTYPE), dims="case")
    flag = stable_flag(floquet, status)
    assert flag.values.tolist() == [1, 0, -1, 0, 1]
    assert flag.attrs["flag_meanings"] == "unstable stable"


def test_reduced_family_harmonics_and_stability(study):
    _, directory, _ = study
    with open_dataset(directory / "map.nc") as ds, \
            open_dataset(directory / "grid.nc") as grid:
        assert not cf_problems(ds) and not cf_problems(grid)
        for name in ("harmonic_ratio_min", "stable", "floquet_multiplier_max"):
            assert name in ds and name in grid, name
        from ced.study.maps import harmonic_ratio

        expect = harmonic_ratio(ds.natural_frequency_min, ds.natural_frequency_max, ds.speed)
        np.testing.assert_allclose(ds.harmonic_ratio_min, expect, rtol=1e-6)
        assert (ds.harmonic_ratio_min >= 0).all()
        unstable = (ds.status.astype(int) & STATUS_FLAGS["parametrically_unstable"]) > 0
        assert ((ds.stable == 0) | ~unstable).all()
        for i in range(ds.sizes["case"]):  # per-case and grid files agree
            c = ds.isel(case=i)
            at = dict(crank=c.crank.item(), coupler=c.coupler.item(), rocker=c.rocker.item(),
                      speed=c.speed.item(), material=c.material.item(), section=c.section.item())
            np.testing.assert_allclose(grid.harmonic_ratio_min.sel(at), c.harmonic_ratio_min)
            np.testing.assert_array_equal(grid.stable.sel(at), c.stable)
