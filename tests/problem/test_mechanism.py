import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.cli import main
from ced.problem.mechanism import (CRANK_INPUT_FAMILIES, FAMILIES, assembly_error, classify,
                                   input_limits)


@pytest.mark.parametrize(
    "lengths, family",
    [
        ((0.5, 0.1, 0.45, 0.35), "crank_rocker"),  # S = crank
        ((0.5, 0.35, 0.45, 0.1), "rocker_crank"),  # S = rocker
        ((0.1, 0.35, 0.45, 0.5), "double_crank"),  # S = ground
        ((0.5, 0.35, 0.1, 0.45), "double_rocker"),  # S = coupler
        ((1.0, 3.0, 2.0, 2.0), "change_point"),  # S + L = 1 + 3 = 2 + 2
        ((1.0, 0.5, 1.0, 0.5), "change_point"),  # parallelogram
        ((1.0, 0.6, 0.7, 0.8), "triple_rocker"),  # S + L = 1.6 > 1.5
        ((0.254, 0.108, 0.2794, 0.2705), "crank_rocker"),  # Sung–Thompson
    ],
)
def test_classify_every_family(lengths, family):
    assert classify(*lengths) == family


def test_grashof_tolerance_boundary():
    # S + L vs P + Q with S=1, L=3, P=Q=2 perturbed through the 1e-9 relative tolerance.
    assert classify(1.0, 3.0 * (1 + 2e-10), 2.0, 2.0) == "change_point"
    assert classify(1.0, 3.0 * (1 - 2e-10), 2.0, 2.0) == "change_point"
    assert classify(1.0, 3.0 * (1 + 1e-8), 2.0, 2.0) == "triple_rocker"
    assert classify(1.0, 3.0 * (1 - 1e-8), 2.0, 2.0) == "double_crank"  # S = ground


def test_classify_rejects_bad_lengths():
    with pytest.raises(ValueError, match="mechanism.crank"):
        classify(1.0, -1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="mechanism.rocker"):
        classify(1.0, 1.0, 1.0, math.nan)


@given(st.lists(st.floats(0.05, 1.0), min_size=4, max_size=4))
@settings(max_examples=300, deadline=None)
def test_input_range_matches_family(lengths):
    g, a, b, c = lengths
    if assembly_error({"type": "four_bar", "ground": g, "crank": a, "coupler": b,
                       "rocker": c}):
        return
    family = classify(g, a, b, c)
    limits = input_limits(g, a, b, c)
    if family in CRANK_INPUT_FAMILIES:
        assert limits.full_rotation
    elif family in ("rocker_crank", "double_rocker", "triple_rocker"):
        assert not limits.full_rotation
        # At each finite limit the dyad B–C–D is stretched or folded: |BD| = b + c or |b − c|.
        for theta in (limits.lower, limits.upper):
            d = math.sqrt(a * a + g * g - 2 * a * g * math.cos(theta))
            assert min(abs(d - (b + c)), abs(d - abs(b - c))) < 1e-9 * (a + b + c + g)


def test_rocker_input_limits_known_case():
    # Rocker-crank (g, a, b, c) = (0.5, 0.35, 0.45, 0.1): |g − a| = 0.15 < |b − c| = 0.35 gives
    # the lower limit at d = 0.35, and g + a = 0.85 > b + c = 0.55 the upper one at d = 0.55.
    lim = input_limits(0.5, 0.35, 0.45, 0.1)
    expected_low = math.acos((0.35**2 + 0.5**2 - 0.35**2) / (2 * 0.35 * 0.5))
    expected_up = math.acos((0.35**2 + 0.5**2 - 0.55**2) / (2 * 0.35 * 0.5))
    assert lim.lower == pytest.approx(expected_low, rel=1e-12)
    assert lim.upper == pytest.approx(expected_up, rel=1e-12)


def test_assembly_error():
    assert assembly_error({"type": "four_bar", "ground": 1.0, "crank": 0.1,
                           "coupler": 0.1, "rocker": 0.1}) is not None
    assert assembly_error({"type": "slider_crank", "crank": 0.2, "rod": 0.15,
                           "offset": 0.0}) is not None
    assert assembly_error({"type": "slider_crank", "crank": 0.15, "rod": 0.3,
                           "offset": 0.05}) is None


def test_families_list_is_the_design_list():
    assert set(FAMILIES) == {"crank_rocker", "rocker_crank", "double_crank", "double_rocker",
                             "change_point", "triple_rocker", "slider_crank"}


def test_cli_classify(capsys):
    assert main(["classify", "--ground", "1", "--crank", "3", "--coupler", "2",
                 "--rocker", "2"]) == 0
    assert capsys.readouterr().out.splitlines()[0] == "change_point"
    assert main(["classify", "--ground", "0.5", "--crank", "0.35", "--coupler", "0.45",
                 "--rocker", "0.1"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("rocker_crank") and "input angle range" in out


def test_cli_classify_bad_input_exit_2(capsys):
    assert main(["classify", "--ground", "1", "--crank", "0.1", "--coupler", "0.1",
                 "--rocker", "0.1"]) == 2
    assert "cannot be assembled" in capsys.readouterr().err
