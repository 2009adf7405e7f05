"""Component-mode synthesis of flexible links (ced.fem.component_modes) against the full FE model."""
import numpy as np
import pytest

from ced.response.batch import make_batch
from ced.problem.scene import load_scene
from ced.simulation.simulate import solve_batch

FOUR_BAR = {
    "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35},
    "links": {"crank": {"flexible": False}},  # flexible coupler and rocker
    "drive": {"speed": 100.0},
    "time": {"revolutions": 1, "steps_per_revolution": 128},
    "modal": {"modes": 3, "angles": 4},
}


def _solve(modes, **changes):
    scene = {**FOUR_BAR, **changes}
    scene["discretization"] = {"elements_per_link": 6, "modes_per_link": modes}
    return solve_batch(make_batch([load_scene(scene)]))


def test_full_basis_reproduces_the_fe_model():
    # 6 elements: 7 nodes × (u, v, θ) = 21 DOFs, 4 end translations, 17 interior rows; 17
    # modes span the interior, the load vectors then vanish, and the basis is complete.
    full, reduced = _solve(0), _solve(17)
    # The modal coordinates relate to the FE interior DOFs through the time-varying boundary
    # projection (q_i = Φη + Ψ T(t) y). The frozen-time stiffness holds motion-induced terms
    # of that projection (M P̈), and time stepping is not invariant under a time-dependent
    # change of variables: frequencies agree to 1e-5 (the elastic parts are congruent), the
    # response to the O(h²) discretization error.
    assert np.allclose(reduced["natural_frequency"], full["natural_frequency"], rtol=1e-5)
    d_full, d_red = full["deflection"], reduced["deflection"]
    assert np.abs(d_red - d_full).max() < 1e-4 * np.abs(d_full).max()
    # Stress compared in magnitude: its sign follows the (tiny) axial strain where bending
    # dominates, by the definition "outer fibre of larger magnitude".
    s_full, s_red = np.abs(full["stress"]), np.abs(reduced["stress"])
    assert np.abs(s_red - s_full).max() < 1e-3 * s_full.max()


def test_quasi_static_response_is_exact_with_one_mode():
    # The static load vectors span K⁻¹ f of every rigid-motion load shape, so the
    # quasi-static response (K q = F, no elastic inertia) is exact whatever the mode count.
    full = _solve(0, effects=["inertia", "gravity"])
    reduced = _solve(1, effects=["inertia", "gravity"])
    assert np.allclose(reduced["stress"], full["stress"], rtol=1e-7,
                       atol=1e-8 * np.abs(full["stress"]).max())


@pytest.mark.parametrize("start", ["undeformed", "periodic"])
def test_few_modes_give_the_low_frequencies_and_peak_stress(start):
    full = _solve(0, time={**FOUR_BAR["time"], "start": start})
    reduced = _solve(4, time={**FOUR_BAR["time"], "start": start})
    assert np.allclose(reduced["natural_frequency"], full["natural_frequency"], rtol=1e-3)
    assert np.allclose(reduced["peak_stress"], full["peak_stress"], rtol=0.02)


def test_cases_with_the_same_link_share_one_basis(monkeypatch):
    # A speed sweep with two materials: the basis is computed once per distinct link (the
    # eigenproblem batch holds one case per material), and every case's reduction equals the
    # one it gets alone.
    from ced.fem import component_modes
    from ced.response.model import build_model
    sizes = []
    eigen = component_modes.natural_frequencies

    def spy(K, M, modes, shapes=False):
        sizes.append(K.shape[0])
        return eigen(K, M, modes, shapes=shapes)
    monkeypatch.setattr(component_modes, "natural_frequencies", spy)
    scenes = [load_scene({**FOUR_BAR, "drive": {"speed": speed},
                          "links": {**FOUR_BAR["links"], "default": {"material": material}},
                          "discretization": {"elements_per_link": 6, "modes_per_link": 3}})
              for material in ("steel", "aluminium") for speed in (60.0, 80.0, 100.0)]
    batch = build_model(make_batch(scenes))
    assert sizes == [2, 2]  # coupler and rocker: one basis per material
    for i, scene in enumerate(scenes):
        alone = build_model(make_batch([scene]))
        for name in ("coupler", "rocker"):
            for field in ("mass", "stiffness", "gyroscopic", "load_constant"):
                got = getattr(batch.links[name], field)[i]
                want = getattr(alone.links[name], field)[0]
                np.testing.assert_allclose(got, want, rtol=1e-12,
                                           atol=1e-12 * np.abs(want).max())
