"""A scene's periodic series as the initial guess of its error estimate's companion
(ced.response.warm_start): mesh-independent samples, the fit back into reduced coordinates,
and the companion's warm-started GMRES."""
import copy

import numpy as np

from ced.auto.error_estimate import companions
from ced.problem.scene import load_scene
from ced.response import collocation
from ced.response.batch import make_batch
from ced.response.elastic import SERIES_SAMPLES
from ced.response.model import build_model, terms_at
from ced.response.warm_start import mesh_free_samples, reduced_from_samples
from ced.simulation.simulate import solve_batch
from tests.response.test_collocation import BLIND_SPOT

#: A default-study crank-rocker at 200 rad/s (test_collocation's scene, another geometry),
#: at a fixed number of points, asking for an error estimate.
SCENE = copy.deepcopy(BLIND_SPOT)
SCENE["mechanism"].update(crank=0.05, coupler=0.25, rocker=0.2)
SCENE["drive"]["speed"] = 200.0
SCENE["time"]["collocation_points"] = 32
SCENE["outputs"]["error_estimate"] = True


def _projection(model, P, compact=False):
    """The joint-coordinate columns of z = P y at P equally spaced phases (case, P, nz, nfree),
    or (``compact``) their rows ``layout.projection_rows``, as the solvers hold them."""
    steps = model.batch.scenes[0]["time"]["steps_per_revolution"]
    times = model.batch.step_size[:, None] * (np.arange(P) * (steps / P))[None, :]
    return terms_at(model, times, compact=compact)[1]


def test_the_samples_of_a_series_fit_back_to_it():
    # On one model the fit inverts the sampling: each link's interior coordinates are
    # determined by u and v at its stations.
    model = build_model(make_batch([load_scene(SCENE)]))
    P, cases = 8, np.array([0])
    projection = _projection(model, P, compact=True)
    y = np.random.default_rng(1).standard_normal((1, P, model.layout.ny)) * 1e-4
    z = model.layout.expand(_projection(model, P), y)
    samples = mesh_free_samples(model, cases, projection, z, y)
    np.testing.assert_allclose(reduced_from_samples(model, cases, projection, samples), y,
                               rtol=0, atol=1e-10 * np.abs(y).max())


def _spy_iterations(monkeypatch):
    """The GMRES iterations of every spectral solve, in order."""
    used = []
    solve = collocation.solve_periodic

    def spy(*args, **kwargs):
        solution = solve(*args, **kwargs)
        used.append(int(solution.iterations.sum()))
        return solution
    monkeypatch.setattr(collocation, "solve_periodic", spy)
    return used


def test_a_companion_started_from_its_scene_converges_to_its_cold_solution_sooner(monkeypatch):
    scene = load_scene(SCENE)
    full = solve_batch(make_batch([scene]))
    guess = full[SERIES_SAMPLES][0]
    assert guess.shape[0] == 32
    companion = companions(scene, 0.0, collocation_points=32)[0].scene
    assert companion["discretization"]["elements_per_link"] == 4
    used = _spy_iterations(monkeypatch)
    cold = solve_batch(make_batch([companion]), peaks_only=True)
    warm = solve_batch(make_batch([companion]), peaks_only=True, guesses=[guess])
    assert warm["collocation_points"][0] == cold["collocation_points"][0] == 32
    # Within GMRES's tolerance (residual 1e-6 of the force), far inside the mesh's error.
    np.testing.assert_allclose(warm["peak_stress"], cold["peak_stress"], rtol=0,
                               atol=1e-5 * cold["peak_stress"].max())
    assert used[1] <= used[0] // 2  # measured: 9 iterations cold, 2 warm
    # The samples do not depend on the mesh's component modes (their number, order and
    # eigh's signs): the companion's own series samples as the scene's does, to within the
    # mesh's error, where their reduced coordinates are not comparable.
    mine = copy.deepcopy(companion)
    mine["outputs"] = {**mine["outputs"], "error_estimate": True}
    own = solve_batch(make_batch([mine]))[SERIES_SAMPLES][0]
    assert np.abs(own - guess).max() <= 0.05 * np.abs(guess).max()


def test_a_guess_at_other_points_is_ignored(monkeypatch):
    scene = load_scene(SCENE)
    guess = solve_batch(make_batch([scene]))[SERIES_SAMPLES][0]
    companion = load_scene({**SCENE, "time": {**SCENE["time"], "collocation_points": 64},
                            "discretization": {**SCENE["discretization"],
                                               "elements_per_link": 4}})
    used = _spy_iterations(monkeypatch)
    cold = solve_batch(make_batch([companion]), peaks_only=True)
    again = solve_batch(make_batch([companion]), peaks_only=True, guesses=[guess])
    np.testing.assert_array_equal(again["peak_stress"], cold["peak_stress"])
    assert used[0] == used[1]
