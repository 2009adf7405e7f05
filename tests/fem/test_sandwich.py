"""The compiled Pᵀ A P of ced.fem.sandwich against the numpy products it replaces."""
import numpy as np
import pytest
import yaml

from ced.fem import effect_terms
from ced.fem.sandwich import link_terms_add, sandwich_add
from ced.problem.scene import load_scene
from ced.response.batch import make_batch
from ced.response.model import build_model, terms_at

EFFECTS = ["inertia", "elastic_inertia", "gravity", "coriolis", "centrifugal",
           "axial_stiffening", "damping"]
FOUR_BAR = {"mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                          "rocker": 0.35},
            "links": {"crank": {"flexible": False}},
            "effects": EFFECTS, "damping": {"model": "rayleigh", "alpha": 1.0, "beta": 1e-5},
            "discretization": {"elements_per_link": 4}}
SLIDER = {"mechanism": {"type": "slider_crank", "crank": 0.1, "rod": 0.3, "offset": 0.02,
                        "slider_mass": 0.5},
          "effects": EFFECTS, "damping": {"model": "modal", "ratio": 0.01},
          "discretization": {"elements_per_link": 3, "modes_per_link": 0}}
# The Watt II of benchmarks/six_bar_cost.py: five links, the crank and ternary rocker rigid.
WATT_II = {"mechanism": {"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                         "rocker": 0.35, "rocker_arm": 0.25, "rocker_arm_angle": 2.5,
                         "coupler2": 0.4, "rocker2": 0.3, "pivot2_x": 0.2, "pivot2_y": -0.3},
           "links": {"crank": {"flexible": False}},
           "effects": EFFECTS, "damping": {"model": "rayleigh", "alpha": 1.0, "beta": 1e-5},
           "discretization": {"formulation": "euler_bernoulli", "elements_per_link": 4}}
# Without the motion-induced terms: no C, and K without the Ṗ, P̈ products.
STILL = ["inertia", "elastic_inertia", "gravity", "axial_stiffening"]


def _terms(raw: dict, compiled: bool, monkeypatch, extras=frozenset({"elastic_mass"})):
    monkeypatch.setattr(effect_terms, "COMPILED", compiled)
    batch = make_batch([load_scene({**raw, "drive": {"speed": s}}) for s in (60.0, 140.0)])
    model = build_model(batch)
    times = batch.step_size[:, None] * np.arange(0.0, 40.0, 3.7)[None, :]
    terms, _ = terms_at(model, times, extras=extras)
    return terms


@pytest.mark.parametrize("raw, extras", [
    (FOUR_BAR, {"elastic_mass"}), (SLIDER, {"elastic_mass"}),
    ({**FOUR_BAR, "discretization": {"elements_per_link": 6, "modes_per_link": 3}},
     {"elastic_mass"}),
    (WATT_II, set()), (WATT_II, {"elastic_mass", "elastic_stiffness"}),
    ({**WATT_II, "effects": STILL}, {"elastic_mass"}),
    ({**WATT_II, "effects": ["coriolis", "gravity"]}, set()),
    ({**FOUR_BAR, "effects": ["centrifugal", "elastic_inertia"]}, {"elastic_stiffness"}),
])
def test_compiled_terms_equal_numpy_terms_to_round_off(raw, extras, monkeypatch):
    numpy_terms = _terms(raw, False, monkeypatch, frozenset(extras))
    compiled_terms = _terms(raw, True, monkeypatch, frozenset(extras))
    for name in ("mass", "damping", "stiffness", "force", "elastic_mass", "elastic_stiffness"):
        a, b = getattr(compiled_terms, name), getattr(numpy_terms, name)
        if b is None:
            assert a is None
            continue
        scale = np.abs(b).max()
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-13 * scale, err_msg=name)


def _projection(T, d, ns, c0, ny):
    """Dense d-th derivative of a link block P = [[0, I_ns], [T, 0]] (case, step, ns + nv, ny):
    ns unit rows onto columns c0 … c0 + ns, then the varying rows T[d] onto the first nf."""
    ncase, nstep, nv, nf = T[d].shape
    p = np.zeros((ncase, nstep, ns + nv, ny))
    if d == 0:
        p[..., :ns, c0:c0 + ns] = np.eye(ns)
    p[..., ns:, :nf] = T[d]
    return p


@pytest.mark.parametrize("left, right", [(0, 0), (0, 1), (1, 0), (2, 2)])
@pytest.mark.parametrize("per_step", [False, True])
def test_blocks_of_the_product(left, right, per_step):
    # out += Pᵀ A P for P = [[0, I_ns], [T, 0]] (rows: ns unit rows, then nv varying rows),
    # the unit rows mapping onto columns c0 … c0 + ns; derivatives of the unit rows vanish.
    rng = np.random.default_rng(left * 10 + right + per_step)
    ncase, nstep, ns, nv, nf, c0 = 2, 3, 4, 3, 2, 3
    ny = c0 + ns
    n = ns + nv
    A = rng.standard_normal((ncase, nstep, n, n) if per_step else (ncase, n, n))
    T = [rng.standard_normal((ncase, nstep, nv, nf)) for _ in range(3)]

    def P(d):
        return _projection(T, d, ns, c0, ny)

    A4 = A if per_step else A[:, None]
    expected = np.swapaxes(P(left), -1, -2) @ A4 @ P(right)
    out = np.zeros((ncase, nstep, ny, ny))
    sandwich_add(out, A, T[left], T[right], ns, c0, left, right)
    np.testing.assert_allclose(out, expected, atol=1e-12)


@pytest.mark.parametrize("ns, nf", [(4, 2), (0, 3), (3, 0)])
@pytest.mark.parametrize("has_m, has_c, centrifugal, nk", [
    (True, True, True, 3), (False, True, False, 1), (True, False, True, 0)])
def test_link_terms_blocks(ns, nf, has_m, has_c, centrifugal, nk):
    # One link's terms against the dense products with P = [[0, I_ns], [T, 0]] as above:
    # M += Pᵀ M_l P, C += Pᵀ 2ωG P + Pᵀ 2M_l Ṗ, K += Pᵀ Σ c_k A_k P [+ Pᵀ 2ωG Ṗ + Pᵀ M_l P̈].
    rng = np.random.default_rng(100 * ns + 10 * nf + nk)
    ncase, nstep, nv, c0 = 2, 3, 3, 3
    ny, n = c0 + ns, ns + nv
    Ml, G = rng.standard_normal((2, ncase, n, n))
    mats = list(rng.standard_normal((nk, ncase, n, n)))
    coefficients = list(rng.standard_normal((nk, ncase, nstep)))
    w = rng.standard_normal((ncase, nstep))
    T = [rng.standard_normal((ncase, nstep, nv, nf)) for _ in range(3)]

    def P(d):
        return _projection(T, d, ns, c0, ny)

    def product(A, right):
        A = A if A.ndim == 4 else A[:, None]
        return np.swapaxes(P(0), -1, -2) @ A @ P(right)

    gyro = 2.0 * w[..., None, None] * G[:, None]
    expected_K = sum((c[..., None, None] * A[:, None] for c, A in zip(coefficients, mats)),
                     np.zeros((ncase, nstep, n, n)))
    expected_K = product(expected_K, 0)
    if centrifugal:
        expected_K += product(gyro, 1) + product(Ml, 2)
    start = rng.standard_normal((3, ncase, nstep, ny, ny))  # the outputs are added to
    M, C, K = start.copy()
    link_terms_add(M if has_m else None, C if has_c else None, K, Ml, G, coefficients, mats,
                   w, T, ns, c0, centrifugal)
    np.testing.assert_allclose(M, start[0] + product(Ml, 0) if has_m else start[0],
                               atol=1e-12)
    np.testing.assert_allclose(
        C, start[1] + product(gyro, 0) + product(2.0 * Ml, 1) if has_c else start[1],
        atol=1e-12)
    np.testing.assert_allclose(K, start[2] + expected_K, atol=1e-12)
