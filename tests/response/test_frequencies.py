"""Natural frequencies over the motion's period (ced.response.frequencies)."""
import math

import numpy as np

from ced.fem.eigenproblem import natural_frequencies
from ced.problem.scene import load_scene
from ced.response.batch import make_batch
from ced.response.frequencies import cycle_frequencies, modal_phases
from ced.response.model import build_model, terms_at
from ced.simulation.simulate import simulate

#: The crank shortest, S + L = P + Q: the change point is passed once a turn, straight onto the
#: other assembly branch; the motion repeats only every two turns.
CHANGE_POINT = {"type": "four_bar", "ground": 0.4, "crank": 0.1, "coupler": 0.35, "rocker": 0.15}
CRANK_ROCKER = {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35}


def _scene(mechanism, angles=16):
    return load_scene({"mechanism": mechanism, "drive": {"speed": 20.0},
                       "discretization": {"elements_per_link": 2},
                       "modal": {"modes": 2, "angles": angles},
                       "time": {"revolutions": 1, "steps_per_revolution": 64}})


def _frozen(model, input_angles):
    """First two frozen frequencies at the given input phases Ωt, Hz, by hand."""
    times = np.asarray(input_angles)[None, :] / model.batch.speed[:, None]
    terms, _ = terms_at(model, times, model.effects - {"damping"}, frozenset({"elastic_mass"}))
    return natural_frequencies(terms.stiffness, terms.elastic_mass, 2)


def test_a_two_turn_motion_is_sampled_over_both_of_its_turns():
    model = build_model(make_batch([_scene(CHANGE_POINT)]))
    assert model.batch.motion_turns.tolist() == [2]
    phases = modal_phases(16)
    got = cycle_frequencies(model, phases, 2)
    np.testing.assert_allclose(got, _frozen(model, 2.0 * phases), rtol=1e-12)
    # The second turn, on the other branch, is not the first again: sampling one turn would
    # miss half of the configurations (and their frequencies).
    first, second = _frozen(model, phases[:8] * 2), _frozen(model, phases[8:] * 2)
    assert np.abs(second - first).max() > 0.05 * np.abs(first).max()


def test_a_one_turn_motion_is_sampled_over_its_turn():
    model = build_model(make_batch([_scene(CRANK_ROCKER)]))
    phases = modal_phases(16)
    np.testing.assert_allclose(cycle_frequencies(model, phases, 2), _frozen(model, phases),
                               rtol=1e-12)


def test_the_dataset_band_spans_both_turns_of_a_change_point():
    ds = simulate([_scene(CHANGE_POINT, angles=32)])
    model = build_model(make_batch([_scene(CHANGE_POINT)]))
    both = _frozen(model, 2.0 * modal_phases(32))
    np.testing.assert_allclose(ds.natural_frequency.values, both, rtol=1e-12)
    one = _frozen(model, modal_phases(32))  # the first turn alone: another band
    assert np.abs(one[0, :, 0].min() - both[0, :, 0].min()) > 0.01 * np.abs(both).max()
