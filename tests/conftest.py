"""Shared test helpers: random assemblable linkages for hypothesis."""
from __future__ import annotations

import fcntl
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, settings
from hypothesis import strategies as st

from ced.problem.mechanism import assembly_error, input_limits


# CI runs the same examples every time (reproducible); local runs keep exploring.
settings.register_profile("ci", derandomize=True, deadline=None)
if os.environ.get("CI"):
    settings.load_profile("ci")


@st.composite
def four_bars(draw):
    """(ground, crank, coupler, rocker, branch) of an assemblable four-bar with margin."""
    lengths = [draw(st.floats(0.05, 1.0)) for _ in range(4)]
    longest = max(lengths)
    # Keep away from flat (degenerate) linkages and from change points, where the closed-form
    # velocity formulas are singular by nature (tested separately).
    if longest > 0.97 * (sum(lengths) - longest):
        lengths[lengths.index(longest)] = 0.9 * (sum(lengths) - longest)
    g, a, b, c = lengths
    # Near a change point the motion's higher derivatives grow without bound (accelerations of
    # ~1e4 rad/s² at |S + L − P − Q| ~ 1e-3), so finite-difference yardsticks lose their
    # accuracy there; change points have their own tests (parallelogram, hard cases).
    s_, p_, q_, l_ = sorted((g, a, b, c))
    assume(abs(s_ + l_ - p_ - q_) > 0.02 * (g + a + b + c))
    branch = draw(st.sampled_from([1.0, -1.0]))
    assert assembly_error({"type": "four_bar", "ground": g, "crank": a,
                           "coupler": b, "rocker": c}) is None
    return g, a, b, c, branch


#: 8th-order central difference weights for the first derivative (offsets −4..4).
FD8 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])


def check_derivatives(r, dt, speed, rtol):
    """Rates and accelerations of a rigid motion sampled at 9 steps dt apart (one case) against
    8th-order central differences of the angles, rates, positions and velocities."""
    for value, derivative in (
        (np.unwrap(r.link_angle[0], axis=0), r.link_angular_velocity[0, 4]),
        (r.link_angular_velocity[0], r.link_angular_acceleration[0, 4]),
        (r.joint_position[0], r.joint_velocity[0, 4]),
        (r.joint_velocity[0], r.joint_acceleration[0, 4]),
    ):
        fd = np.tensordot(FD8, value, axes=(0, 0)) / dt
        # Where the derivative vanishes (a dwell), the difference quotient is round-off only:
        # |value| × speed, the derivative's natural size, keeps the relative check meaningful.
        natural = np.abs(value).max() * speed
        scale = np.abs(derivative).max() + np.abs(fd).max() + natural
        assert np.abs(fd - derivative).max() < rtol * scale


def drive_of(g, a, b, c, amplitude=0.9):
    """(mid or initial angle, amplitude or NaN) for the input of a four-bar."""
    lim = input_limits(g, a, b, c)
    if lim.full_rotation:
        return 0.3, np.nan
    return lim.mid, amplitude * lim.half_range


def shared(tmp_path_factory, name: str, build) -> Path:
    """``build(directory)`` once per test session, even across pytest-xdist workers (they share
    the parent of their base temporary directories; a file lock serializes them)."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent
    directory = root / name
    with open(root / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (directory / ".done").exists():
            shutil.rmtree(directory, ignore_errors=True)
            directory.mkdir()
            build(directory)
            (directory / ".done").touch()
    return directory


@pytest.fixture(scope="session")
def reference_four_bar_peak() -> float:
    """Converged peak stress of config/scenes/reference_four_bar.yaml, Pa: reduced fine meshes
    (modal truncation below 1e-5) extrapolated at order 2 in space and in time."""
    import yaml

    from ced.simulation.simulate import simulate

    def peak(ne, spr):
        raw = yaml.safe_load(open("config/scenes/reference_four_bar.yaml"))
        raw.pop("modal")
        raw["discretization"] = {"elements_per_link": ne, "modes_per_link": 4}
        raw["time"]["steps_per_revolution"] = spr
        raw["outputs"] = {"error_estimate": False}
        return float(simulate(raw).peak_stress.max())

    fine, space, time = peak(128, 1024), peak(64, 1024), peak(128, 512)
    return fine + (fine - space) / 3.0 + (fine - time) / 3.0


def corpus_header(path: Path, key: str) -> str:
    """The ``# key: value`` header line of a bad-input corpus file (tests/bad_*)."""
    import re

    match = re.search(rf"^# {key}: (.*)$", path.read_text(), re.MULTILINE)
    assert match, f"{path.name} lacks a '# {key}:' line"
    return match.group(1).strip()


def mutate_container(data, target, junk, new_keys) -> None:
    """Replace, delete or insert one entry of a dict or list (in place), for the parser fuzz
    tests. ``junk`` draws the new values, ``new_keys`` the keys inserted into a dict."""
    action = data.draw(st.sampled_from(["replace", "delete", "insert"]), label="action")
    if isinstance(target, dict):
        if action == "insert" or not target:
            target[data.draw(new_keys, label="new key")] = data.draw(junk)
            return
        key = data.draw(st.sampled_from(sorted(target, key=str)), label="key")
        if action == "delete":
            del target[key]
        else:
            target[key] = data.draw(junk)
    elif action == "insert" or not target:
        target.insert(data.draw(st.integers(0, len(target))), data.draw(junk))
    elif action == "delete":
        del target[data.draw(st.integers(0, len(target) - 1))]
    else:
        target[data.draw(st.integers(0, len(target) - 1))] = data.draw(junk)


STEEL_SIMEON = {"E": 2.0e11, "rho": 7870.0, "nu": 0.3}
SQUARE_8MM = {"shape": "rectangle", "height": 0.008, "width": 0.008}


def simeon(**changes):
    """Simeon's (1996) flexible slider-crank: crank 0.15 m rigid at 150 rad/s, rod 0.30 m
    8 × 8 mm steel pinned at both ends, slider 0.075552 kg, no gravity, no damping."""
    scene = {
        "mechanism": {"type": "slider_crank", "crank": 0.15, "rod": 0.30,
                      "slider_mass": 0.075552},
        "links": {"default": {"material": STEEL_SIMEON, "section": SQUARE_8MM},
                  "crank": {"flexible": False}},
        "drive": {"speed": 150.0},
        "effects": ["inertia", "elastic_inertia", "coriolis", "centrifugal",
                    "axial_stiffening"],
        "discretization": {"elements_per_link": 8},
        "time": {"revolutions": 1, "steps_per_revolution": 512, "start": "periodic"},
        "modal": {"modes": 3, "angles": 12},
    }
    for key, value in changes.items():
        scene[key] = {**scene.get(key, {}), **value} if isinstance(value, dict) else value
    return scene
