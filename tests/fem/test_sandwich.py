"""The compiled Pᵀ A P of ced.fem.sandwich against the numpy products it replaces."""
import numpy as np
import pytest
import yaml

from ced.fem import effect_terms
from ced.fem.sandwich import sandwich_add
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


def _terms(raw: dict, compiled: bool, monkeypatch):
    monkeypatch.setattr(effect_terms, "COMPILED", compiled)
    batch = make_batch([load_scene({**raw, "drive": {"speed": s}}) for s in (60.0, 140.0)])
    model = build_model(batch)
    times = batch.step_size[:, None] * np.arange(0.0, 40.0, 3.7)[None, :]
    terms, _ = terms_at(model, times, extras=frozenset({"elastic_mass"}))
    return terms


@pytest.mark.parametrize("raw", [FOUR_BAR, SLIDER,
                                 {**FOUR_BAR, "discretization": {"elements_per_link": 6,
                                                                 "modes_per_link": 3}}])
def test_compiled_terms_equal_numpy_terms_to_round_off(raw, monkeypatch):
    numpy_terms = _terms(raw, False, monkeypatch)
    compiled_terms = _terms(raw, True, monkeypatch)
    for name in ("mass", "damping", "stiffness", "force", "elastic_mass"):
        a, b = getattr(compiled_terms, name), getattr(numpy_terms, name)
        if b is None:
            assert a is None
            continue
        scale = np.abs(b).max()
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-13 * scale, err_msg=name)


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
        p = np.zeros((ncase, nstep, n, ny))
        if d == 0:
            p[..., :ns, c0:] = np.eye(ns)
        p[..., ns:, :nf] = T[d]
        return p

    A4 = A if per_step else A[:, None]
    expected = np.swapaxes(P(left), -1, -2) @ A4 @ P(right)
    out = np.zeros((ncase, nstep, ny, ny))
    sandwich_add(out, A, T[left], T[right], ns, c0, left, right)
    np.testing.assert_allclose(out, expected, atol=1e-12)
