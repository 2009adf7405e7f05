"""The KED model of a batch (ced.response.model): conservation, damping, effects built."""
import numpy as np
import pytest

from ced.fem.eigenproblem import natural_frequencies
from ced.problem.errors import SceneError
from ced.problem.scene import load_scene
from ced.response.batch import make_batch
from ced.response.integrators import march, newmark, start
from ced.response.model import build_model, terms_at
from ced.simulation.simulate import simulate
from tests.conftest import simeon


def test_undamped_free_vibration_energy_is_bounded():
    # Frozen mechanism matrices (t = 0), free vibration from a random displacement with
    # average-acceleration Newmark: ½vᵀMv + ½qᵀKq conserved to round-off over 10,000 steps.
    scene = load_scene(simeon(effects=["elastic_inertia"]))
    model = build_model(make_batch([scene]))
    terms, _ = terms_at(model, np.zeros((1, 1)))
    M, K = terms.mass[:, 0], terms.stiffness[:, 0]
    n = M.shape[-1]
    frozen = lambda k: (M, None, K, np.zeros((1, n, 1)))  # noqa: E731
    rng = np.random.default_rng(1)
    q0 = rng.normal(size=(1, n, 1)) * 1e-4
    energy = []

    def record(k, state):
        q, v = state.q[0, :, 0], state.v[0, :, 0]
        energy.append(0.5 * v @ M[0] @ v + 0.5 * q @ K[0] @ q)
    march(newmark(), frozen, np.array([2e-5]), 10_000, start(frozen, q0, 0 * q0), record)
    energy = np.array(energy)
    assert np.abs(energy / energy[0] - 1).max() < 1e-9


def test_modal_damping_gives_every_mode_the_ratio():
    # At any instant, not only at the start: 2ζω on the diagonal of the frozen modes' damping
    # (to the table's interpolation tolerance, ced.response.modal_damping.TOLERANCE).
    scene = load_scene(simeon(effects=["elastic_inertia", "damping"],
                              damping={"model": "modal", "ratio": 0.02}))
    model = build_model(make_batch([scene]))
    times = np.array([[0.0, 0.0123, 0.0371, 0.05]])
    terms, _ = terms_at(model, times)
    for k in range(times.shape[1]):
        f, phi = natural_frequencies(terms.stiffness[:, k], terms.mass[:, k], 5, shapes=True)
        modal_c = np.swapaxes(phi, -1, -2) @ terms.damping[:, k] @ phi
        np.testing.assert_allclose(np.diag(modal_c[0]), 2 * 0.02 * 2 * np.pi * f[0], rtol=1e-2)


def test_effects_not_requested_are_not_built():
    scene = load_scene(simeon(effects=["inertia"]))
    model = build_model(make_batch([scene]))
    terms, _ = terms_at(model, np.zeros((1, 2)))
    assert terms.mass is None and terms.damping is None  # quasi-static, no Coriolis
    ds = simulate({**simeon(effects=["inertia"])})
    assert "natural_frequency" in ds  # modal asked for
    assert "floquet_multiplier_max" not in ds  # quasi-static: no shooting
    rigid = simulate({**simeon(), "discretization": {"formulation": "rigid"}})
    assert "stress" not in rigid and "natural_frequency" not in rigid


def test_more_modes_per_link_than_interior_dofs_is_refused():
    # Like modal.modes beyond the model's DOFs: one Euler–Bernoulli element of the clamped
    # crank has 6 DOFs, 4 end translations and 1 clamped rotation, so 1 interior DOF.
    scene = load_scene(simeon(discretization={"elements_per_link": 1, "modes_per_link": 512},
                              links={"crank": {"flexible": True}}))
    with pytest.raises(SceneError) as err:
        build_model(make_batch([scene]))
    assert err.value.path == "discretization.modes_per_link"
    assert "only 1 interior degrees of freedom" in err.value.message


@pytest.mark.parametrize("effects", [
    ["inertia", "elastic_inertia", "coriolis", "centrifugal", "axial_stiffening", "gravity"],
    ["inertia", "elastic_inertia", "axial_stiffening"],
    ["elastic_inertia", "axial_stiffening", "gravity"],
    ["inertia", "elastic_inertia", "gravity"]])
def test_compiled_ternary_loads_are_the_numpy_ones_bit_for_bit(monkeypatch, effects):
    """A six-bar's ternary rocker: its resultant loads and geometric stiffness from the
    compiled pass, as from numpy's expressions (CED_KERNEL=numpy), whatever the effects."""
    import ced.response.model as model_module
    from tests.rigid.test_dyads import WATT_II

    scenes = [load_scene({"mechanism": WATT_II, "effects": effects, "gravity": [0.4, -9.81],
                          "point_masses": {"C": 0.2, "E": 0.1}, "drive": {"speed": w}})
              for w in (10.0, 45.0)]
    out = []
    for compiled in (True, False):
        monkeypatch.setattr(model_module, "COMPILED", compiled)
        model = build_model(make_batch(scenes))
        times = model.batch.step_size[:, None] * np.arange(0.0, 40.0, 1.3)[None]
        terms, _ = terms_at(model, times)
        out.append(terms)
    for name in ("mass", "damping", "stiffness", "force"):
        a, b = getattr(out[0], name), getattr(out[1], name)
        assert (a is None and b is None) or np.array_equal(a, b), name
