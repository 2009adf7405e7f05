"""The reference flexible four-bar in Exudyn: the peer model of ced's peer benchmark.

Problem (the same as ced's ``config/scenes/reference_four_bar.yaml`` with ``start: undeformed``)
--------------------------------------------------------------------------------------------
- Four-bar: ground pivots A = (0, 0) and D = (0.5, 0) m; crank A→B 0.1 m, coupler B→C 0.45 m,
  rocker D→C 0.35 m; crank angle 0 at t = 0, open branch (C above the line B→D), as in ced
  (``ced/problem/mechanism.py``, ``ced/rigid/kinematics.py``).
- All links steel, E = 210 GPa, rho = 7850 kg/m³ (``ced/problem/data/materials.yaml``),
  rectangle 10 mm (out of plane) × 5 mm (in plane): A = 5e-5 m², I = 1.0417e-10 m⁴.
- Crank and rocker rigid (mass and centroidal inertia of slender bars of that section);
  coupler flexible: ``ObjectANCFCable2D`` elements (planar, geometrically exact
  Euler–Bernoulli ANCF cable: nonlinear axial strain |r'| − 1 and curvature), pinned at its
  two end nodes (the joint centres B and C) by ``RevoluteJoint2D`` to the crank and rocker.
- Crank driven at constant Ω from t = 0, pivot A a ``RevoluteJoint2D`` to ground. Its rotation
  is prescribed by a ``CoordinateConstraint`` on the crank node's angle: ``--drive velocity``
  (default) θ' = Ω at velocity level, compiled code only, which the integrator turns into
  θ(t) = Ω t exactly (checked: 1e-12 rad after two turns); ``--drive position`` θ = Ω t at
  position level through a Python offset user function (same peaks to 1e-9, slower).
- Start undeformed: every node at its rigid position at t = 0, with the velocity of the rigid
  motion (nodal velocities and slope rates of the coupler, COM velocities and angular
  velocities of crank and rocker); consistent initial accelerations are computed by Exudyn.
- No gravity, no damping. Two revolutions, t_end = 4π/Ω; fixed step 2π/(Ω·steps), implicit
  generalized-α (spectral radius 0.9, index 3; ced's default is generalized-α with
  rho_inf = 0.9 too), Newton relative tolerance 1e-8, absolute 1e-6 (1e-6 is above the
  residual floor of the finest steps; peaks change by < 1e-8 relative against 1e-10).
- Output: peak coupler strain = max over the time steps and over 21 equally spaced stations
  along the coupler (s/L = 0, 0.05, …, 1, the stations of ced's ``outputs: {stations: 21}``)
  of (h/2)·|κ|, h = 5 mm, κ the curvature of the ANCF element (``CurvatureLocal``).
- Solver time: wall time of ``exudyn.SolveDynamic`` only (not model building), one thread.

Run (inside the peer venv that ``benchmarks/peer/setup_peer.sh`` creates):

    benchmarks/.peer-venv/bin/python benchmarks/peer/exudyn_four_bar.py \
        --elements 8 --steps 1024 --speeds 90 100 110

prints one JSON object: exudyn version, the setting, and per speed the peak strain and the
solver seconds. ``--speeds-json FILE`` reads the speeds from a JSON list instead.
``--revolutions R --damping-beta β`` run R revolutions with stiffness-proportional damping
of the coupler (β in s) and add each revolution's peak: the steady-state benchmark
(``benchmarks/peer/steady_state.py``).
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
    sys.exit(f"exudyn_four_bar: cannot import exudyn ({exc}); run benchmarks/peer/setup_peer.sh")

# ------------------------------------------------------------------------------ the problem
GROUND, CRANK, COUPLER, ROCKER = 0.5, 0.1, 0.45, 0.35  # m
E, RHO = 2.10e11, 7850.0  # Pa, kg/m³ (ced's steel)
WIDTH, HEIGHT = 0.010, 0.005  # m: out of plane, in plane
AREA = WIDTH * HEIGHT
INERTIA = WIDTH * HEIGHT**3 / 12.0
STATIONS = 21
REVOLUTIONS = 2
SPECTRAL_RADIUS = 0.9
NEWTON_RTOL = 1e-8
NEWTON_ATOL = 1e-6  # residual floor of fine steps is ~1e-7; peaks change < 1e-8 rel.
SHOW_HINTS = bool(os.environ.get("PEER_SHOW_HINTS"))

PROBLEM = {
    "mechanism": {"ground": GROUND, "crank": CRANK, "coupler": COUPLER, "rocker": ROCKER,
                  "initial_crank_angle": 0.0, "branch": "open"},
    "material": {"E": E, "rho": RHO},
    "section": {"width_out_of_plane": WIDTH, "height_in_plane": HEIGHT, "area": AREA,
                "second_moment": INERTIA},
    "links": {"crank": "rigid", "coupler": "flexible (ANCFCable2D)", "rocker": "rigid"},
    "start": "undeformed (rigid position and rigid velocity field at t = 0)",
    "revolutions": REVOLUTIONS,
    "gravity": 0.0, "damping": 0.0,
    "output": "max over time and 21 stations of (h/2)|curvature| on the coupler",
}


def rigid_state(omega: float, theta2: float = 0.0) -> dict:
    """Closed-form rigid positions and velocities of the four-bar (ced's conventions).

    Returns link angles th2, th3, th4 (rad), angular velocities w2, w3, w4 (rad/s) and the
    joint positions/velocities B, C, vB, vC (m, m/s) for crank angle ``theta2`` at speed Ω.
    """
    a, b, c, g = CRANK, COUPLER, ROCKER, GROUND
    B = np.array([a * math.cos(theta2), a * math.sin(theta2)])
    D = np.array([g, 0.0])
    BD = D - B
    d = math.hypot(*BD)
    psi = math.atan2(BD[1], BD[0])
    beta = math.acos((b * b + d * d - c * c) / (2.0 * b * d))
    th3 = psi + beta  # open branch: C on the left of B→D
    C = B + b * np.array([math.cos(th3), math.sin(th3)])
    th4 = math.atan2(C[1] - D[1], C[0] - D[0])
    s34 = math.sin(th3 - th4)
    w3 = a * omega * math.sin(th4 - theta2) / (b * s34)
    w4 = a * omega * math.sin(th3 - theta2) / (c * s34)
    perp = lambda t: np.array([-math.sin(t), math.cos(t)])  # noqa: E731
    vB = a * omega * perp(theta2)
    vC = c * w4 * perp(th4)
    return {"th2": theta2, "th3": th3, "th4": th4, "w2": omega, "w3": w3, "w4": w4,
            "B": B, "C": C, "D": D, "vB": vB, "vC": vC}


def build(omega: float, elements: int, steps: int, drive: str = "velocity",
          revolutions: int = REVOLUTIONS, damping_beta: float = 0.0):
    """Build the Exudyn model; returns (SC, mbs, simulationSettings, sensors, info).

    ``damping_beta`` (s) is stiffness-proportional damping of the coupler, the same as ced's
    ``damping: {model: rayleigh, beta: …}``: bending moment EI(κ + β κ̇), axial force
    EA(ε + β ε̇) (the cable's bending and axial damping, EI β and EA β)."""
    st = rigid_state(omega)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ii.ObjectGround())
    mGroundA = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=ground, localPosition=[0, 0, 0]))
    mGroundD = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=ground,
                                                   localPosition=[GROUND, 0, 0]))
    nGround = mbs.AddNode(ii.NodePointGround(referenceCoordinates=[0, 0, 0]))
    mGroundCoord = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=nGround, coordinate=0))

    def rigid_bar(length, pivot, angle, w, pivot_velocity):
        """A rigid bar of the section, node at its centre of mass (x, y, θ)."""
        e = np.array([math.cos(angle), math.sin(angle)])
        n = np.array([-math.sin(angle), math.cos(angle)])
        com = pivot + 0.5 * length * e
        vcom = pivot_velocity + 0.5 * length * w * n
        mass = RHO * AREA * length
        node = mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=[com[0], com[1], angle],
                                              initialVelocities=[vcom[0], vcom[1], w]))
        body = mbs.AddObject(ii.ObjectRigidBody2D(nodeNumber=node, mass=mass,
                                                  inertia=mass * length**2 / 12.0))
        return node, body

    nCrank, bCrank = rigid_bar(CRANK, np.zeros(2), st["th2"], omega, np.zeros(2))
    nRocker, bRocker = rigid_bar(ROCKER, st["D"], st["th4"], st["w4"], np.zeros(2))

    # Crank: pivot A on ground, rotation prescribed θ = Ω t (displacement of the node's
    # rotation coordinate, whose reference value is the initial angle 0).
    mCrankA = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=bCrank,
                                                  localPosition=[-0.5 * CRANK, 0, 0]))
    mCrankB = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=bCrank,
                                                  localPosition=[0.5 * CRANK, 0, 0]))
    mbs.AddObject(ii.ObjectJointRevolute2D(markerNumbers=[mGroundA, mCrankA]))
    mCrankTheta = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=nCrank, coordinate=2))

    if drive == "position":
        # θ − Ω t = 0 at position level, through a Python user function (called from the
        # Newton loop: slower).
        def crank_angle(mbs, t, itemNumber, lOffset):
            return omega * t

        def crank_speed(mbs, t, itemNumber, lOffset):
            return omega

        mbs.AddObject(ii.ObjectConnectorCoordinate(markerNumbers=[mGroundCoord, mCrankTheta],
                                                   offsetUserFunction=crank_angle,
                                                   offsetUserFunction_t=crank_speed))
    elif drive == "velocity":
        # θ' = Ω at velocity level, no Python in the loop; with θ(0) = 0 and a constant Ω the
        # Newmark/generalized-α update integrates it exactly: θ(t) = Ω t to 1e-12 rad.
        mbs.AddObject(ii.ObjectConnectorCoordinate(markerNumbers=[mGroundCoord, mCrankTheta],
                                                   velocityLevel=True, offset=omega))
    else:
        raise ValueError(f"drive must be 'velocity' or 'position', got {drive!r}")
    # Rocker: pivot D on ground, C at its far end.
    mRockerD = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=bRocker,
                                                   localPosition=[-0.5 * ROCKER, 0, 0]))
    mRockerC = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=bRocker,
                                                   localPosition=[0.5 * ROCKER, 0, 0]))
    mbs.AddObject(ii.ObjectJointRevolute2D(markerNumbers=[mGroundD, mRockerD]))

    # Coupler: ANCF cable, straight along B→C with unit slope, rigid velocity field.
    th3, w3 = st["th3"], st["w3"]
    e3 = np.array([math.cos(th3), math.sin(th3)])
    n3 = np.array([-math.sin(th3), math.cos(th3)])
    le = COUPLER / elements
    nodes = []
    for k in range(elements + 1):
        s = k * le
        r = st["B"] + s * e3
        v = st["vB"] + s * w3 * n3
        slope_rate = w3 * n3
        nodes.append(mbs.AddNode(ii.NodePoint2DSlope1(
            referenceCoordinates=[r[0], r[1], e3[0], e3[1]],
            initialVelocities=[v[0], v[1], slope_rate[0], slope_rate[1]])))
    cables = []
    for k in range(elements):
        cables.append(mbs.AddObject(ii.ObjectANCFCable2D(
            nodeNumbers=[nodes[k], nodes[k + 1]], length=le, massPerLength=RHO * AREA,
            bendingStiffness=E * INERTIA, axialStiffness=E * AREA,
            bendingDamping=E * INERTIA * damping_beta, axialDamping=E * AREA * damping_beta)))
    mCouplerB = mbs.AddMarker(ii.MarkerNodePosition(nodeNumber=nodes[0]))
    mCouplerC = mbs.AddMarker(ii.MarkerNodePosition(nodeNumber=nodes[-1]))
    mbs.AddObject(ii.ObjectJointRevolute2D(markerNumbers=[mCrankB, mCouplerB]))
    mbs.AddObject(ii.ObjectJointRevolute2D(markerNumbers=[mCouplerC, mRockerC]))

    # Curvature at the 21 stations (element and local position of each station).
    sensors = []
    for j in range(STATIONS):
        s = COUPLER * j / (STATIONS - 1)
        k = min(int(s / le), elements - 1)
        x = min(max(s - k * le, 0.0), le)
        sensors.append(mbs.AddSensor(ii.SensorBody(
            bodyNumber=cables[k], localPosition=[x, 0, 0], storeInternal=True,
            writeToFile=False, outputVariableType=exu.OutputVariableType.CurvatureLocal)))
    mbs.Assemble()

    h = 2.0 * math.pi / (omega * steps)
    t_end = revolutions * 2.0 * math.pi / omega
    sim = simulation_settings(revolutions * steps, t_end)
    info = {"nodes": {"crank": nCrank, "rocker": nRocker, "coupler": nodes}, "h": h,
            "t_end": t_end}
    return SC, mbs, sim, sensors, info


def simulation_settings(n_steps: int, t_end: float):
    """Fixed steps of implicit generalized-α (ρ∞ = 0.9, consistent initial accelerations),
    Newton to :data:`NEWTON_RTOL`, sensors stored at every step, no files, one thread."""
    sim = exu.SimulationSettings()
    ti = sim.timeIntegration
    ti.numberOfSteps = n_steps
    ti.endTime = t_end
    ti.adaptiveStep = False
    ti.verboseMode = 0
    ti.generalizedAlpha.spectralRadius = SPECTRAL_RADIUS
    ti.generalizedAlpha.computeInitialAccelerations = True
    ti.newton.relativeTolerance = NEWTON_RTOL
    ti.newton.absoluteTolerance = NEWTON_ATOL
    sim.solution.file.write = False
    sim.solution.sensors.writePeriod = 0.5 * t_end / n_steps  # every step
    sim.parallel.numberOfThreads = 1
    return sim


def run_case(omega: float, elements: int, steps: int, check: bool = False,
             drive: str = "velocity", revolutions: int = REVOLUTIONS,
             damping_beta: float = 0.0) -> dict:
    """Peak coupler strain and solver seconds of one speed; with more than one revolution
    also the peak within each revolution (``peak_strain_by_revolution``: the k-th is over
    the steps k·n < j ≤ (k+1)·n, n steps a revolution, the start excluded)."""
    SC, mbs, sim, sensors, info = build(omega, elements, steps, drive, revolutions,
                                        damping_beta)
    t0 = time.perf_counter()
    ok = exu.SolveDynamic(mbs, sim, solverType=exu.DynamicSolverType.GeneralizedAlpha,
                          showHints=SHOW_HINTS)
    seconds = time.perf_counter() - t0
    if ok is False:
        raise RuntimeError(f"Exudyn SolveDynamic failed at Omega={omega}")
    kappa = np.stack([mbs.GetSensorStoredData(s)[:, 1] for s in sensors], axis=1)
    times = mbs.GetSensorStoredData(sensors[0])[:, 0]
    strain = 0.5 * HEIGHT * np.abs(kappa)
    out = {"speed": omega, "peak_strain": float(strain.max()), "solver_seconds": seconds,
           "samples": int(len(times))}
    if revolutions > 1:
        # Samples are stored at every step from t = 0: sample j is step j.
        turn = np.minimum((np.arange(len(times)) - 1) // steps, revolutions - 1)
        by_turn = np.zeros(revolutions)
        np.maximum.at(by_turn, turn[1:], strain[1:].max(axis=1))
        out["peak_strain_by_revolution"] = by_turn.tolist()
    if check:
        # Crank angle follows Ω t exactly; end time reached; where the peak is.
        theta = mbs.GetNodeOutput(info["nodes"]["crank"], exu.OutputVariableType.Coordinates)[2]
        out["crank_angle_error"] = float(theta - omega * info["t_end"])
        out["t_last"] = float(times[-1])
        it, js = np.unravel_index(np.argmax(strain), strain.shape)
        out["peak_time"] = float(times[it])
        out["peak_station"] = float(js / (STATIONS - 1))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--elements", type=int, default=8)
    p.add_argument("--steps", type=int, default=1024, help="steps per revolution")
    p.add_argument("--speeds", type=float, nargs="*", default=None)
    p.add_argument("--speeds-json", default=None)
    p.add_argument("--check", action="store_true")
    p.add_argument("--drive", choices=("velocity", "position"), default="velocity")
    p.add_argument("--revolutions", type=int, default=REVOLUTIONS)
    p.add_argument("--damping-beta", type=float, default=0.0,
                   help="stiffness-proportional damping of the coupler, s")
    args = p.parse_args(argv)
    if args.speeds_json:
        with open(args.speeds_json) as f:
            speeds = [float(x) for x in json.load(f)]
    else:
        speeds = args.speeds or [100.0]
    cases = [run_case(w, args.elements, args.steps, args.check, args.drive, args.revolutions,
                      args.damping_beta) for w in speeds]
    json.dump({"exudyn": exu.__version__, "python": platform.python_version(),
               "elements": args.elements, "steps_per_revolution": args.steps,
               "drive": args.drive, "revolutions": args.revolutions,
               "damping_beta": args.damping_beta,
               "cases": cases}, sys.stdout)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
