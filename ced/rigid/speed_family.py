"""Cases that differ in their input speed alone share one rigid solution, at unit speed.

At a fixed phase φ = Ωt of the input (a crank's θ0 + φ, an oscillating input's
θ_mid + A sin φ) a rigid linkage's configuration does not depend on the speed Ω; its
velocities are proportional to Ω and its accelerations to Ω² (v = J(θ) θ̇ and
a = J θ̈ + (dJ/dθ) θ̇², with θ̇ ∝ Ω and θ̈ ∝ Ω²). The Newton–Euler system's matrix depends on
the configuration and the masses alone, and its right-hand side is Ω² × (d'Alembert forces
at unit speed) + (gravity), so that every joint force and the input torque is P + Ω² Q.

On a step grid of N steps per input period every case passes the same phases 2πk/N,
whatever its speed. The cases of a *family* (everything of their rigid problem equal but
the speed) take their motion from one solution at unit speed, scaled, and their forces from
two solutions of its systems, P (gravity alone) and Q (the d'Alembert forces at unit speed),
as P + Ω² Q — the same to round-off as solving each case (tests/rigid/test_speed_family.py).
Every case is so derived, alone in its family or not, so that its bits do not depend on
which other cases share its batch (a batch solved in parts equals one batch, bit for bit).
A sweep over speeds solves one case's rigid motion and forces per geometry instead of
every case's (:class:`ced.response.batch.Batch`).
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

from .inverse_dynamics import BodyProperties, InverseDynamics
from .kinematics import RigidMotion

__all__ = ["SpeedFamilies", "speed_families", "bodies_at_cases", "scaled_motion",
           "combined_forces"]


class SpeedFamilies(NamedTuple):
    """The cases of a batch grouped by everything of their rigid problem but the speed.

    ``nodes`` (family,) holds each family's first case, whose rigid problem is solved at
    unit speed; ``family`` (case,) indexes ``nodes``: each case's family."""

    nodes: np.ndarray
    family: np.ndarray


def speed_families(keys: list[bytes]) -> SpeedFamilies:
    """Group the cases by ``keys`` (one per case: everything of its rigid problem but the
    speed).

    Parameters
    ----------
    keys : list of bytes
        Per case, its rigid problem without the speed.
    """
    first: dict[bytes, int] = {}
    family = np.array([first.setdefault(key, len(first)) for key in keys], np.int64)
    nodes = np.empty(len(first), np.int64)
    nodes[family[::-1]] = np.arange(len(keys))[::-1]  # the first case of each
    return SpeedFamilies(nodes, family)


def bodies_at_cases(bodies: BodyProperties, cases: np.ndarray) -> BodyProperties:
    """``bodies`` of some cases.

    Parameters
    ----------
    bodies : BodyProperties
        Mass properties, each (case, …).
    cases : numpy.ndarray
        Indices into their case axis, int, shape (n,).
    """
    return BodyProperties(**{f.name: None if getattr(bodies, f.name) is None
                             else getattr(bodies, f.name)[cases]
                             for f in dataclasses.fields(bodies)})


def scaled_motion(unit: RigidMotion, families: SpeedFamilies, speed: np.ndarray,
                  time: np.ndarray) -> RigidMotion:
    """Every case's motion from its family's at unit speed: the configuration as it is, the
    velocities × Ω and the accelerations × Ω².

    Parameters
    ----------
    unit : RigidMotion
        Each family's motion at unit speed (family, step, …), at the phases of ``time``.
    families : SpeedFamilies
    speed : numpy.ndarray
        Input speed per case, rad/s, shape (case,).
    time : numpy.ndarray
        Each case's times, s, shape (case, step).
    """
    at = families.family
    w, w2 = speed[:, None], (speed * speed)[:, None]

    def rows(mapping):
        return None if mapping is None else {k: v[at] for k, v in mapping.items()}

    slide = None if unit.slide is None else {
        name: (s[at], rate[at] * w, acc[at] * w2) for name, (s, rate, acc) in unit.slide.items()}
    return dataclasses.replace(
        unit, time=time, lengths=unit.lengths[at], link_angle=unit.link_angle[at],
        link_angular_velocity=unit.link_angular_velocity[at] * w[..., None],
        link_angular_acceleration=unit.link_angular_acceleration[at] * w2[..., None],
        joint_position=unit.joint_position[at],
        joint_velocity=unit.joint_velocity[at] * w[..., None, None],
        joint_acceleration=unit.joint_acceleration[at] * w2[..., None, None],
        singular=unit.singular[at], guide_angle=rows(unit.guide_angle), slide=slide,
        branch=rows(unit.branch))


def combined_forces(gravity: InverseDynamics | None, inertia: InverseDynamics | None,
                    families: SpeedFamilies, speed: np.ndarray) -> InverseDynamics:
    """Every case's forces P + Ω² Q from its family's P (gravity alone) and Q (the
    d'Alembert forces at unit speed, no gravity).

    Parameters
    ----------
    gravity : InverseDynamics or None
        P of each family (family, step, …); None where gravity is zero.
    inertia : InverseDynamics or None
        Q of each family; None without the d'Alembert forces. Not both None.
    families : SpeedFamilies
    speed : numpy.ndarray
        Input speed per case, rad/s, shape (case,).
    """
    at = families.family
    square = speed * speed

    def combine(p, q):
        if p is None and q is None:
            return None
        scale = None if q is None else square.reshape((-1,) + (1,) * (q.ndim - 1))
        if p is None:
            return scale * q[at]
        return p[at] if q is None else p[at] + scale * q[at]

    some = gravity if gravity is not None else inertia
    return InverseDynamics(**{
        f.name: combine(None if gravity is None else getattr(gravity, f.name),
                        None if inertia is None else getattr(inertia, f.name))
        for f in dataclasses.fields(some)})
