"""The elastic response's own axial force in the geometric stiffness (effect
``elastic_axial_force``, :mod:`ced.response.axial_force`)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ced
import ced.response.elastic as elastic
from ced.problem.scene import load_scene
from ced.problem.status import STATUS_FLAGS
from ced.response.axial_force import (ElasticAxialForce, added_axial_force, axial_strain,
                                      relative_change)
from ced.response.batch import make_batch
from ced.response.integrators import integrator_for
from ced.response.model import build_model
from ced.response.period_terms import period_terms

finite = st.floats(-1e3, 1e3)

#: The Watt II of benchmarks/peer/linkages.py, its couplers flexible, lightly damped.
WATT_II = {"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35,
           "rocker_arm": 0.25, "rocker_arm_angle": 2.5, "coupler2": 0.4, "rocker2": 0.3,
           "pivot2_x": 0.2, "pivot2_y": -0.3}
#: The independent code's peak outer-fibre strain of its coupler at 50 rad/s (Exudyn, 32
#: geometrically exact ANCF cables, 8192 steps a revolution: benchmarks/peer_linkages.json).
PEER_COUPLER_PEAK = 3.2107470791740403e-04
LINEAR = ["inertia", "elastic_inertia", "coriolis", "centrifugal", "axial_stiffening",
          "damping"]


def watt_ii(effects, elements=6, steps=1024, speed=50.0):
    section = {"shape": "rectangle", "height": 0.005, "width": 0.01}
    links = {"default": {"material": "steel", "section": section, "flexible": False},
             "coupler": {"flexible": True}, "coupler2": {"flexible": True}}
    return {"mechanism": WATT_II, "links": links, "drive": {"speed": speed},
            "effects": effects, "damping": {"model": "rayleigh", "beta": 1e-5},
            "discretization": {"elements_per_link": elements},
            "time": {"revolutions": 2, "steps_per_revolution": steps, "start": "undeformed"},
            "outputs": {"stations": 21, "error_estimate": False}}


def coupler_peak(ds) -> float:
    links = [str(x) for x in ds["link"].values]
    return float(np.abs(ds["bending_strain"][0, :, links.index("coupler")]).max())


@settings(max_examples=50, deadline=None)
@given(st.lists(finite, min_size=12, max_size=12), st.floats(1e-4, 1.0))
def test_the_added_force_is_exact_at_the_steps_and_linear_between(values, step):
    c = np.array(values).reshape(3, 1, 4)
    force = ElasticAxialForce(np.array([step]), {"link": c})
    steps = np.arange(4.0)[None, :] * step
    assert np.allclose(force.at("link", steps), c, rtol=1e-12, atol=1e-9)
    half = force.at("link", (np.arange(3.0)[None, :] + 0.5) * step)
    assert np.allclose(half, 0.5 * (c[..., :-1] + c[..., 1:]), rtol=1e-12, atol=1e-9)
    beyond = force.at("link", np.array([[10.0 * step]]))
    assert np.allclose(beyond[..., 0], c[..., -1], rtol=1e-12, atol=1e-9)


@settings(max_examples=50, deadline=None)
@given(finite, finite, finite, st.floats(0.05, 2.0), st.floats(1e5, 1e9))
def test_a_quadratic_axial_force_is_fitted_exactly(n0, n1, n2, length, ea):
    stations = np.linspace(0.0, 1.0, 21)
    s = length * stations
    force = n0 + n1 * s + n2 * s * s
    # Two steps: the force at the second, none at the first; a static strain subtracted.
    static = np.full((1, 2, 21), 3e-6)
    strain = static + np.stack([0.0 * s, force / ea])[None]
    out = added_axial_force({"bar": strain}, {"bar": static}, {"bar": np.array([ea])},
                            {"bar": np.array([length])}, stations)["bar"]
    # Round-off: of the force, and of EA × the static strain it is taken from.
    atol = 1e-9 * max(abs(n0), abs(n1) * length, abs(n2) * length**2) + 1e-12 * ea * 3e-6
    assert out.shape == (3, 1, 2)
    assert np.allclose(out[:, 0, 0] * [1.0, length, length**2], 0.0, rtol=0, atol=atol)
    assert np.allclose(out[:, 0, 1] * [1.0, length, length**2],
                       [n0, n1 * length, n2 * length**2], rtol=0, atol=atol)


def test_axial_strain_is_the_recovered_one():
    """The strain the iteration reads is the one the outputs store."""
    scene = load_scene(watt_ii(LINEAR, steps=64))
    model = build_model(make_batch([scene]))
    layout = model.layout
    rng = np.random.default_rng(0)
    qz = rng.normal(size=(1, 5, layout.nz)) * 1e-4
    mine = axial_strain(model.recovery, layout.link_offsets, layout.link_sizes, qz)
    fields = elastic._recover_numpy(model, qz, None, True)["axial_strain"]
    links = list(layout.topology.links)
    for name, eps in mine.items():
        assert np.allclose(eps, fields[:, :, links.index(name)], rtol=1e-5, atol=1e-12)
    assert set(mine) == {"coupler", "coupler2"}


def test_relative_change_per_case():
    old = np.zeros((2, 3, 4))
    new = old.copy()
    new[0, 1, 2] = 2.0
    new[0, 0, 0] = 4.0
    assert relative_change(new, old).tolist() == [1.0, 0.0]
    assert relative_change(new, new).tolist() == [0.0, 0.0]


@pytest.mark.slow
def test_the_watt_ii_coupler_meets_the_independent_code_with_the_elastic_force():
    """The Watt II's coupler at 50 rad/s: its axial force from the rigid motion alone leaves
    its peak strain 1.4 % above the geometrically exact peer's, the elastic joint forces
    of coupler2 (through the ternary rocker) counted too bring it within 0.3 %."""
    linear = coupler_peak(ced.simulate(watt_ii(LINEAR)))
    second = ced.simulate(watt_ii(LINEAR[:5] + ["elastic_axial_force", "damping"]))
    assert int(second["status"][0]) == 0
    assert abs(linear / PEER_COUPLER_PEAK - 1.0) > 0.01  # the check can tell them apart
    assert abs(coupler_peak(second) / PEER_COUPLER_PEAK - 1.0) < 0.003


def test_a_case_whose_iteration_does_not_settle_is_flagged(monkeypatch):
    """One iteration only: the response still changes by more than the tolerance; the case
    keeps its linear response and says that its second-order model has no answer."""
    monkeypatch.setattr(elastic, "MAX_ITERATIONS", 1)
    ds = ced.simulate(watt_ii(LINEAR[:5] + ["elastic_axial_force", "damping"], 4, 256))
    assert int(ds["status"][0]) & STATUS_FLAGS["large_deflection"]
    linear = ced.simulate(watt_ii(LINEAR, 4, 256))
    assert np.array_equal(ds["bending_strain"].values, linear["bending_strain"].values)
    monkeypatch.setattr(elastic, "MAX_ITERATIONS", 12)
    ds = ced.simulate(watt_ii(LINEAR[:5] + ["elastic_axial_force", "damping"], 4, 256))
    assert int(ds["status"][0]) == 0


def test_without_elastic_inertia_the_effect_adds_nothing():
    """Quasi-static, the response's axial strain is the quasi-static one: nothing to add."""
    quasi = ["inertia", "axial_stiffening"]
    a = ced.simulate(watt_ii(quasi, 4, 128))
    b = ced.simulate(watt_ii(quasi + ["elastic_axial_force"], 4, 128))
    assert np.array_equal(a["bending_strain"].values, b["bending_strain"].values)


def test_the_step_by_step_march_is_the_periodic_one_with_nothing_added():
    """An iteration's path (terms step by step, the generic march) with an added force of
    zero gives the linear response of the period terms' compiled march, to round-off."""
    scenes = [load_scene(watt_ii(LINEAR, 4, 256, speed)) for speed in (30.0, 60.0)]
    linear = ced.simulate(scenes)
    model = build_model(make_batch(scenes))
    batch, layout = model.batch, model.layout
    n_steps = batch.n_steps
    zero = {name: np.zeros((3, batch.size, n_steps + 1)) for name in model.recovery}
    iterate = dataclasses.replace(model, elastic_axial_force=ElasticAxialForce(
        batch.step_size, zero))
    q0 = np.zeros((batch.size, layout.ny, 1))
    y = elastic.march_every_step(iterate, integrator_for(scenes[0]["time"]), n_steps, q0,
                                 q0.copy())
    period = period_terms(model, batch.step_size, batch.period_steps)
    steps = np.arange(n_steps + 1)
    qz = elastic._expand(layout, period, y, steps)
    fields = elastic._recover_numpy(model, qz, None, True)
    scale = np.abs(linear["bending_strain"].values).max()
    assert np.abs(fields["bending_strain"] - linear["bending_strain"].values).max() < 1e-5 * scale


def test_a_diverging_iteration_keeps_the_linear_response(monkeypatch):
    """An iterate that is no longer finite (as near buckling) is not returned: the case keeps
    its linear response, finite, and is flagged."""
    calls = []
    march = elastic.march_every_step

    def failing(*args, **kwargs):
        y = march(*args, **kwargs)
        calls.append(1)
        if len(calls) == 2:
            y[:, -1] = np.inf
        return y

    monkeypatch.setattr(elastic, "march_every_step", failing)
    ds = ced.simulate(watt_ii(LINEAR[:5] + ["elastic_axial_force", "damping"], 4, 256))
    assert len(calls) == 2
    assert int(ds["status"][0]) & STATUS_FLAGS["large_deflection"]
    linear = ced.simulate(watt_ii(LINEAR, 4, 256))
    assert np.array_equal(ds["bending_strain"].values, linear["bending_strain"].values)


def test_the_periodic_state_is_where_a_damped_transient_settles():
    """From a periodic start the added force is periodic and each iteration is a periodic
    solve; from a start at rest each one marches the run. Damped (ζ ≈ 9 % at the first mode),
    the transient forgets its start: its fourth revolution is the periodic state, each path
    forming its force on its own. At 80 rad/s the effect moves that state by 1.2 % of its
    peak; the two paths agree to 3e-5."""
    effects = LINEAR[:5] + ["elastic_axial_force", "damping"]
    runs = {}
    for name, scene_effects, start, revolutions in (("periodic", effects, "periodic", 1),
                                                     ("transient", effects, "quasi_static", 4),
                                                     ("linear", LINEAR, "periodic", 1)):
        scene = watt_ii(scene_effects, 4, 128, 80.0)
        scene["damping"] = {"model": "rayleigh", "beta": 5e-4}
        scene["time"].update(start=start, revolutions=revolutions)
        ds = ced.simulate(scene)
        assert int(ds["status"][0]) == 0
        runs[name] = ds["bending_strain"].values[0][-129:]
    scale = np.abs(runs["periodic"]).max()
    moved = np.abs(runs["linear"] - runs["periodic"]).max()
    assert moved > 5e-3 * scale  # the effect changes the periodic state ...
    assert np.abs(runs["transient"] - runs["periodic"]).max() < 0.01 * moved  # ... alike


@settings(max_examples=50, deadline=None)
@given(st.lists(finite, min_size=9, max_size=9), st.floats(1e-4, 1.0), st.integers(0, 5))
def test_a_periodic_added_force_repeats_every_period(values, step, turns):
    """Over P = 3 steps, given at steps 0 … 3 (the last equal to the first)."""
    c = np.array(values).reshape(3, 1, 3)
    c = np.concatenate([c, c[..., :1]], axis=-1)
    force = ElasticAxialForce(np.array([step]), {"link": c}, period=3)
    times = (np.array([[0.0, 1.0, 2.5]]) + 3 * turns) * step
    expected = np.stack([c[..., 0], c[..., 1], 0.5 * (c[..., 2] + c[..., 0])], axis=-1)
    assert np.allclose(force.at("link", times), expected, rtol=1e-9, atol=1e-7)


def test_an_undamped_periodic_state_near_resonance_keeps_its_linear_response():
    """The Watt II at 57.8 rad/s, undamped, from a periodic start: its largest Floquet
    multiplier is 1 − 1e-5, so a small change of stiffness moves the periodic state a lot,
    and the iterates drift away (each change 1.6× the last). The case keeps its linear
    state, flagged, instead of a last iterate 11× off."""
    mechanism = {**WATT_II}
    scenes = [{"mechanism": mechanism, "links": {"crank": {"flexible": False}},
               "drive": {"speed": 57.79692884153313}, "effects": effects,
               "discretization": {"formulation": "euler_bernoulli", "elements_per_link": 4},
               "time": {"revolutions": 1, "steps_per_revolution": 256, "start": "periodic"},
               "outputs": {"error_estimate": False}}
              for effects in (LINEAR[:5], LINEAR[:5] + ["elastic_axial_force"])]
    linear, second = (ced.simulate(s) for s in scenes)
    assert int(linear["status"][0]) == 0
    assert int(second["status"][0]) == STATUS_FLAGS["large_deflection"]
    assert np.array_equal(second["peak_stress"].values, linear["peak_stress"].values)
