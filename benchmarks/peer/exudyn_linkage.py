"""A planar linkage of rigid bodies and flexible links in Exudyn: the peer of a ced linkage.

Runs inside the peer venv (``benchmarks/peer/setup_peer.sh``); it does not import ced. The
linkage comes as JSON (written by ``benchmarks/peer/linkages.py`` from ced's description of
the mechanism, so that both codes start from the same geometry):

- ``links``: per link its two end joints ``[P, Q]``, whether it is ``flexible``, its length,
  its angle θ₀ at t = 0 (rad, the direction P→Q) and its angular velocity at unit input speed
  (rad/s per rad/s); a rigid link also its ``mass`` (kg), ``inertia`` about its centre of
  mass (kg m²), ``centre`` and the ``points`` of its joints (m, in its frame: origin P, x
  along P→Q). A ternary link is a rigid link with three points.
- ``joints``: per joint the two ``bodies`` it connects (``ground`` or a link) and its
  position (m) and velocity at unit input speed (m/s per rad/s) at t = 0.
- ``input``: the driven link (rigid, pivoted to ground at its first joint);
  ``material`` (E, rho) and ``section`` (area, second_moment, height) of every link;
  optionally ``damping_beta`` (s): Kelvin–Voigt damping of the flexible links, bending
  β·EI and axial β·EA on the rates of curvature and axial strain (Rayleigh's βK).

Model:

- A rigid link is a ``NodeRigidBody2D`` + ``ObjectRigidBody2D`` at its centre of mass; its
  joints are ``MarkerBodyPosition`` at their points.
- A flexible link is ``elements`` ``ObjectANCFCable2D`` (geometrically exact planar
  Euler–Bernoulli cable), straight from P to Q at t = 0, pinned at its end nodes.
- Every joint is an ``ObjectJointRevolute2D``; the input's rotation θ' = Ω is prescribed at
  velocity level on its node's angle (``ObjectConnectorCoordinate``): θ(t) = Ω t exactly.
- Start undeformed with the rigid velocity field (velocities × Ω); no gravity;
  implicit generalized-α (ρ∞ = 0.9, index 3), fixed steps, Newton relative tolerance 1e-8.

Output (one JSON object on stdout): per speed, per flexible link the peak outer-fibre bending
strain (h/2)|κ| over the steps and ``stations`` equally spaced stations, where it is, and the
signed strain at that station; the input torque and every joint's force magnitude, all at
``record`` equally spaced times of the run (with the time), for the comparison of the rigid
results; the solver's wall time. With ``--frequencies N``: the N lowest natural frequencies
of the linkage frozen at t = 0, at rest, its input held (needs scipy).

    benchmarks/.peer-venv/bin/python benchmarks/peer/exudyn_linkage.py linkage.json \\
        --elements 16 --steps 4096 --speeds 60 90
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

try:
    import exudyn as exu  # noqa: E402
    from exudyn import itemInterface as ii  # noqa: E402
except ImportError as exc:  # pragma: no cover - the harness checks this
    sys.exit(f"exudyn_linkage: cannot import exudyn ({exc}); run benchmarks/peer/setup_peer.sh")

# The reference four-bar's integrator settings (generalized-α, ρ∞ = 0.9, Newton 1e-8).
from exudyn_four_bar import simulation_settings  # noqa: E402


def _rotation(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def build(linkage: dict, omega: float, elements: int, steps: int, revolutions: float,
          stations: int, record: int, fixed: bool = False):
    """The Exudyn system of ``linkage`` at input speed ``omega`` (rad/s); with ``fixed`` the
    input's angle held at θ₀ at position level (the frozen linkage of :func:`frequencies`)."""
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ii.ObjectGround())
    E, rho = linkage["material"]["E"], linkage["material"]["rho"]
    area, second = linkage["section"]["area"], linkage["section"]["second_moment"]
    # Kelvin–Voigt damping of the cables' strain rates: stiffness-proportional (Rayleigh β).
    beta = linkage.get("damping_beta", 0.0)
    joints, links = linkage["joints"], linkage["links"]
    position = {j: np.array(d["position"], float) for j, d in joints.items()}
    velocity = {j: omega * np.array(d["velocity"], float) for j, d in joints.items()}
    marker: dict[tuple[str, str], int] = {}  # (body, joint) -> marker
    nodes: dict[str, int] = {}
    cables: dict[str, list] = {}
    for name, link in links.items():
        P, Q = link["joints"]
        theta, w = link["angle"], omega * link["angular_velocity"]
        R = _rotation(theta)
        if link["flexible"]:
            e, n = R[:, 0], R[:, 1]
            le = link["length"] / elements
            chain = []
            for k in range(elements + 1):
                s = k * le
                r = position[P] + s * e
                v = velocity[P] + s * w * n
                chain.append(mbs.AddNode(ii.NodePoint2DSlope1(
                    referenceCoordinates=[r[0], r[1], e[0], e[1]],
                    initialVelocities=[v[0], v[1], w * n[0], w * n[1]])))
            cables[name] = [mbs.AddObject(ii.ObjectANCFCable2D(
                nodeNumbers=[chain[k], chain[k + 1]], length=le, massPerLength=rho * area,
                bendingStiffness=E * second, axialStiffness=E * area,
                bendingDamping=beta * E * second, axialDamping=beta * E * area))
                for k in range(elements)]
            marker[name, P] = mbs.AddMarker(ii.MarkerNodePosition(nodeNumber=chain[0]))
            marker[name, Q] = mbs.AddMarker(ii.MarkerNodePosition(nodeNumber=chain[-1]))
            others = set(link.get("points", {})) - {P, Q}
            if others:
                raise ValueError(f"flexible link {name} carries joints {sorted(others)} "
                                 "between its ends: not modelled here")
            continue
        centre = np.array(link["centre"], float)
        com = position[P] + R @ centre
        arm = R @ centre
        vcom = velocity[P] + w * np.array([-arm[1], arm[0]])
        node = mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=[com[0], com[1], theta],
                                              initialVelocities=[vcom[0], vcom[1], w]))
        body = mbs.AddObject(ii.ObjectRigidBody2D(nodeNumber=node, mass=link["mass"],
                                                  inertia=link["inertia"]))
        nodes[name] = node
        for j, point in link["points"].items():
            local = np.array(point, float) - centre
            marker[name, j] = mbs.AddMarker(ii.MarkerBodyPosition(
                bodyNumber=body, localPosition=[local[0], local[1], 0.0]))
    joint_objects = {}
    for j, d in joints.items():
        pair = []
        for b in d["bodies"]:
            if b == "ground":
                pair.append(mbs.AddMarker(ii.MarkerBodyPosition(
                    bodyNumber=ground, localPosition=[*position[j], 0.0])))
            else:
                pair.append(marker[b, j])
        joint_objects[j] = mbs.AddObject(ii.ObjectJointRevolute2D(markerNumbers=pair))
    # The drive: θ' = Ω on the input's node angle (its reference is θ₀).
    inp = linkage["input"]
    if links[inp]["flexible"]:
        raise ValueError("the input link must be rigid")
    ground_node = mbs.AddNode(ii.NodePointGround(referenceCoordinates=[0, 0, 0]))
    drive = mbs.AddObject(ii.ObjectConnectorCoordinate(
        markerNumbers=[mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=ground_node,
                                                             coordinate=0)),
                       mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=nodes[inp],
                                                             coordinate=2))],
        velocityLevel=not fixed, offset=0.0 if fixed else omega))
    h = 2.0 * math.pi / (omega * steps)
    n_steps = int(round(revolutions * steps))
    curvature = {}
    for name, chain in cables.items():
        le = links[name]["length"] / elements
        curvature[name] = []
        for k in range(stations):
            s = links[name]["length"] * k / (stations - 1)
            e = min(int(s / le), elements - 1)
            curvature[name].append(mbs.AddSensor(ii.SensorBody(
                bodyNumber=chain[e], localPosition=[min(max(s - e * le, 0.0), le), 0, 0],
                storeInternal=True, writeToFile=False,
                outputVariableType=exu.OutputVariableType.CurvatureLocal)))
    every = max(1, n_steps // record)
    forces = {j: mbs.AddSensor(ii.SensorObject(
        objectNumber=o, storeInternal=True, writeToFile=False,
        outputVariableType=exu.OutputVariableType.Force)) for j, o in joint_objects.items()}
    torque = mbs.AddSensor(ii.SensorObject(objectNumber=drive, storeInternal=True,
                                           writeToFile=False,
                                           outputVariableType=exu.OutputVariableType.Force))
    mbs.Assemble()
    sim = simulation_settings(n_steps, n_steps * h)
    return mbs, sim, curvature, forces, torque, every


def run_case(linkage: dict, omega: float, elements: int, steps: int, revolutions: float,
             stations: int, record: int) -> dict:
    mbs, sim, curvature, forces, torque, every = build(linkage, omega, elements, steps,
                                                      revolutions, stations, record)
    t0 = time.perf_counter()
    ok = exu.SolveDynamic(mbs, sim, solverType=exu.DynamicSolverType.GeneralizedAlpha,
                          showHints=False)
    seconds = time.perf_counter() - t0
    if ok is False:
        raise RuntimeError(f"Exudyn SolveDynamic failed at Omega={omega}")
    height = linkage["section"]["height"]
    out = {"speed": omega, "solver_seconds": seconds, "peak_strain": {}}
    for name, sensors in curvature.items():
        kappa = np.stack([mbs.GetSensorStoredData(s)[:, 1] for s in sensors], axis=1)
        strain = 0.5 * height * np.abs(kappa)
        it, js = np.unravel_index(np.argmax(strain), strain.shape)
        times = mbs.GetSensorStoredData(sensors[0])[:, 0]
        out["peak_strain"][name] = {"value": float(strain.max()), "time": float(times[it]),
                                    "station": float(js / (stations - 1))}
        # The signed bending strain at the station of the peak, at the recorded times.
        out.setdefault("strain_history", {})[name] = (
            0.5 * height * kappa[::every, js]).tolist()
    data = mbs.GetSensorStoredData(torque)
    out["time"] = data[::every, 0].tolist()
    out["input_torque"] = data[::every, 1].tolist()
    out["joint_force_magnitude"] = {
        j: np.hypot(*mbs.GetSensorStoredData(s)[::every, 1:3].T).tolist()
        for j, s in forces.items()}
    return out


def frequencies(linkage: dict, elements: int, count: int) -> list[float]:
    """The ``count`` lowest natural frequencies, Hz, of the linkage frozen at t = 0 and at
    rest, its input held: Exudyn's eigenvalues of the constrained system (the constraint
    Jacobian's null space); values below 0.01 Hz, numerical zeros, dropped (the held
    linkage has no rigid-body mode)."""
    mbs, sim, *_ = build(linkage, 1e-9, elements, 64, 1.0, 2, 1, fixed=True)
    found, _ = mbs.ComputeODE2Eigenvalues(sim, useSparseSolver=False, convert2Frequencies=True,
                                          useAbsoluteValues=True, ignoreAlgebraicEquations=False)
    found = np.sort(np.asarray(found))
    return found[found > 0.01][:count].tolist()


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("linkage", help="JSON description (module docstring)")
    p.add_argument("--elements", type=int, default=8)
    p.add_argument("--steps", type=int, default=1024, help="steps per revolution")
    p.add_argument("--revolutions", type=float, default=2.0)
    p.add_argument("--stations", type=int, default=21)
    p.add_argument("--record", type=int, default=128, help="samples of the force histories")
    p.add_argument("--speeds", type=float, nargs="+", default=[100.0])
    p.add_argument("--frequencies", type=int, default=0,
                   help="print this many natural frequencies of the frozen linkage instead")
    args = p.parse_args(argv)
    with open(args.linkage) as f:
        linkage = json.load(f)
    if args.frequencies:
        json.dump({"exudyn": exu.__version__, "elements": args.elements,
                   "frequencies": frequencies(linkage, args.elements, args.frequencies)},
                  sys.stdout)
        sys.stdout.write("\n")
        return 0
    cases = [run_case(linkage, w, args.elements, args.steps, args.revolutions, args.stations,
                      args.record) for w in args.speeds]
    json.dump({"exudyn": exu.__version__, "python": platform.python_version(),
               "elements": args.elements, "steps_per_revolution": args.steps,
               "revolutions": args.revolutions, "cases": cases}, sys.stdout)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
