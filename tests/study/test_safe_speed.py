"""Safe speed limits (ced.study.safe_speed): credibility, the rule, the texts and the table."""
import json

import numpy as np
import pytest

from ced.io import write_dataset
from ced.problem.status import STATUS_FLAGS
from ced.study.safe_speed import (credibility, limit_text, safe_speed, safe_speed_table,
                                  section_label, write_safe_speed_table)
from tests.study.test_maps import synthetic


def test_credibility_names_every_disqualifying_flag_and_a_large_error():
    flags = STATUS_FLAGS
    status = [0, flags["large_deflection"], flags["resonant"] | flags["near_singular"],
              flags["tolerance_unmet"], 0, 0, np.nan, flags["thick_link"]]
    error = [0.01, 0.01, 0.01, 0.01, 0.41, np.nan, 0.01, 0.0]
    assert credibility(status, error, 0.05) == [
        "", "large_deflection", "resonant", "tolerance_unmet", "error estimate 41 % > 5 %",
        "", "failed", "thick_link"]  # near_singular alone is a warning, not a disqualifier
    assert credibility([0], [0.41], 0.5) == [""]


def test_safe_speed_rule():
    # ascending whatever the order; every lower speed must pass (300 passing again is no help)
    assert safe_speed([300, 100, 200, 50], ["", "", "stress", ""]) == (
        100.0, "stress at 200 rad/s")
    assert safe_speed([50, 100], ["", ""]) == (100.0, "grid top")
    assert safe_speed([50, 100], ["large_deflection", ""]) == (
        None, "large_deflection at 50 rad/s")


def test_limit_text_marks_lower_bounds_and_gives_rpm():
    assert limit_text(200.0, "grid top") == "≥ 200 rad/s (1910 rpm, grid top)"
    assert limit_text(50.0, "resonant at 55 rad/s") == "50 rad/s (477 rpm)"  # 50·60/2π = 477.5
    assert limit_text(None, "failed at 5 rad/s") == "none (failed at 5 rad/s)"


def test_section_label():
    assert section_label({"shape": "rectangle", "height": 0.0016, "width": 0.0254}) == \
        "rectangle 1.6 × 25.4 mm (h × w)"
    assert section_label({"shape": "circle", "diameter": 0.012}) == "circle ⌀ 12 mm"


def summary():
    """synthetic() (crank 0.1/0.2 x speed 50/100 x steel/brass, 7 cases) with the inputs of the
    table: utilisation, fatigue factor, error estimate, status."""
    ds = synthetic()
    n = ds.sizes["case"]
    ds["status"][:] = 0
    use = np.full((n, 2), 0.5)
    fatigue = np.full((n, 2), 3.0)
    error = np.full(n, 0.01)
    cases = {(float(c), float(s), str(m)): i for i, (c, s, m) in
             enumerate(zip(ds.crank.values, ds.speed.values, ds.material.values))}
    # crank 0.1 steel: both speeds pass -> lower bound at the grid top (100)
    # crank 0.1 brass: 100 rad/s has an error estimate of 41 % -> 50, ended by the estimate
    error[cases[0.1, 100.0, "brass"]] = 0.41
    # crank 0.2 steel (50 only): large deflection -> none
    ds["status"][cases[0.2, 50.0, "steel"]] = STATUS_FLAGS["large_deflection"]
    # crank 0.2 brass: yield passes at both, fatigue fails at 100 -> yield ≥ 100, fatigue 50
    fatigue[cases[0.2, 100.0, "brass"], 1] = 1.5
    ds["stress_utilisation"] = (("case", "link"), use, {"units": "1"})
    ds["fatigue_safety_factor"] = (("case", "link"), fatigue, {"units": "1"})
    ds["error_estimate"] = ("case", error, {"units": "1"})
    ds.attrs["study_sections"] = json.dumps([{"shape": "rectangle", "height": 0.02,
                                              "width": 0.01}])
    return ds


def test_safe_speed_table():
    table = safe_speed_table([summary()], 2.0, fatigue_safety_factor=2.0, error_tolerance=0.05)
    rows = {(r.crank, r.material): r for r in table.itertuples()}
    top = rows[0.1, "steel"]
    assert top.safe_speed == "≥ 100 rad/s (955 rpm, grid top)" and top.safe_speed_is_lower_bound
    assert top.safe_speed_rpm == pytest.approx(100 * 60 / (2 * np.pi))
    assert top.section == "rectangle 20 × 10 mm (h × w)"
    assert top.yield_strength_MPa == 235 and top.endurance_limit_MPa == 180
    estimate = rows[0.1, "brass"]
    assert estimate.safe_speed == "50 rad/s (477 rpm)"
    assert estimate.limited_by == "error estimate 41 % > 5 % at 100 rad/s"
    none = rows[0.2, "steel"]
    assert none.safe_speed == "none (large_deflection at 50 rad/s)"
    assert np.isnan(none.safe_speed_rad_s)
    fatigue = rows[0.2, "brass"]
    assert fatigue.yield_limit.startswith("≥ 100 rad/s")
    assert fatigue.fatigue_limit == "50 rad/s (477 rpm)"
    assert fatigue.safe_speed_rad_s == 50.0
    assert fatigue.limited_by == "fatigue factor 1.50 < 2 at 100 rad/s"


def test_unknown_strengths_end_the_range_and_say_so():
    ds = summary()
    ds["stress_utilisation"][0, 0] = np.nan  # crank 0.1, 50 rad/s, steel: no yield strength
    ds["fatigue_safety_factor"][:] = np.nan
    rows = {(r.crank, r.material): r for r in safe_speed_table([ds]).itertuples()}
    assert rows[0.1, "steel"].yield_limit == "none (yield strength unknown at 50 rad/s)"
    assert rows[0.1, "brass"].fatigue_limit == "none (endurance limit unknown at 50 rad/s)"


def test_written_tables(tmp_path):
    write_dataset(summary(), tmp_path / "f.nc")
    write_safe_speed_table([str(tmp_path / "f.nc")], tmp_path / "t.csv", tmp_path / "t.md")
    header = (tmp_path / "t.csv").read_text().splitlines()[0].split(",")
    for column in ("yield_limit", "fatigue_limit", "safe_speed_rad_s", "safe_speed_rpm",
                   "limited_by", "section"):
        assert column in header
    text = (tmp_path / "t.md").read_text()
    assert "| crank_rocker | 4 | 1 | 1 | 0 | 1 |" in text  # 4 rows: top 1, none 1, fatigue 1
    assert "≥ 100 rad/s (955 rpm, grid top)" in text
