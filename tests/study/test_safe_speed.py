"""Safe speed limits (ced.study.safe_speed): the rule and the table."""
import numpy as np

from ced.io import write_dataset
from ced.study.safe_speed import safe_speed, safe_speed_table, write_safe_speed_table
from tests.study.test_maps import synthetic


def test_safe_speed_rule():
    y = 235e6
    # monotone: 2 x 100 <= 235 at 50 and 100, 2 x 130 > 235 at 200
    assert safe_speed([50, 100, 200], [80e6, 100e6, 130e6], [0, 0, 0], y) == 100.0
    # non-monotone: 200 fails, 300 passes again -> still 100 (every lower speed must pass)
    assert safe_speed([300, 100, 200, 50], [90e6, 60e6, 130e6, 50e6], [0] * 4, y) == 100.0
    # all pass -> the highest speed; the lowest fails -> None ("none")
    assert safe_speed([50, 100], [1e6, 2e6], [0, 0], y) == 100.0
    assert safe_speed([50, 100], [200e6, 2e6], [0, 0], y) is None
    # flags: resonant (4) at 100 stops the range; large_deflection (1) alone does not
    assert safe_speed([50, 100, 150], [1e6] * 3, [0, 4, 0], y) == 50.0
    assert safe_speed([50, 100, 150], [1e6] * 3, [1, 0, 0], y) == 150.0
    # failed (NaN stress) and unknown yield strength
    assert safe_speed([50, 100], [1e6, np.nan], [0, 16], y) == 50.0
    assert np.isnan(safe_speed([50], [1e6], [0], None))
    # the safety factor
    assert safe_speed([50, 100], [80e6, 100e6], [0, 0], y, stress_safety_factor=2.5) == 50.0


def test_safe_speed_table(tmp_path):
    ds = synthetic()  # crank 0.1/0.2 x speed 50/100 x material steel/brass (no yield: unknown)
    stress = np.array([[100e6, 1.0], [110e6, 1.0], [100e6, 1.0], [130e6, 1.0],
                       [200e6, 1.0], [100e6, 1.0], [1e6, 1.0]])
    ds["peak_stress"] = (("case", "link"), stress[:ds.sizes["case"]], ds.peak_stress.attrs)
    ds["material"] = ds.material.where(ds.material != "brass", "steel_cold")  # unknown name
    table = safe_speed_table([ds], 2.0)
    rows = {(r.crank, r.material): r.safe_speed for r in table.itertuples()}
    got = {}
    for i in range(ds.sizes["case"]):
        got.setdefault((float(ds.crank[i]), str(ds.material[i].item())), []).append(
            (float(ds.speed[i]), float(stress[i, 0]), int(ds.status[i])))
    for key, cases in got.items():
        expect = "unknown" if key[1] != "steel" else None
        if expect is None:
            limit = None
            for speed, s, st in sorted(cases):
                if 2 * s > 235e6 or st & 4:
                    break
                limit = speed
            expect = "none" if limit is None else f"{limit:g}"
        assert rows[key] == expect, (key, cases)
    write_dataset(ds, tmp_path / "f.nc")
    write_safe_speed_table([str(tmp_path / "f.nc")], tmp_path / "t.csv", tmp_path / "t.md")
    assert "safe_speed" in (tmp_path / "t.csv").read_text().splitlines()[0]
    assert "| crank_rocker |" in (tmp_path / "t.md").read_text()
