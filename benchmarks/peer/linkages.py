"""ced against an independent multibody code (Exudyn) on the reference four-bar and the
six-bars (issue 18).

The reference four-bar of the peer benchmark (``benchmarks/peer/compare.py``, flexible
coupler), the Watt II and the Stephenson III of the tests (:data:`LINKAGES`: two four-bars in
series through the ternary rocker D–C–E; a dyad driven from the point E of the ternary
coupler B–C–E), steel bars 10 mm × 5 mm (5 mm in plane), no gravity, two revolutions from
the undeformed state. Four comparisons for each:

1. **Rigid.** Every link rigid. The input torque and the magnitude of the force at every
   joint over the two revolutions, ced's rigid analysis (closed-form dyads, Newton–Euler)
   against Exudyn's index-3 DAE integration of the same bodies with the crank's rotation
   prescribed, relative to each history's largest value: the second loop's kinematics, the
   ternary link's mass, centre and inertia, and the inverse dynamics. The first
   :data:`START_UP` of a revolution is reported apart: there the peer's generalized-α
   accelerations (and so its forces) still carry the start-up transient of an index-3
   integration, which decays with the steps taken (3.5e-3–5.9e-3 of the largest value 32
   steps after the start at 4096 steps a revolution; the Watt II's 2e-4 64 steps after it
   at 8192).
2. **Natural frequencies** of the linkage frozen at t = 0, at rest, its input held, with each
   of its flexible links alone and all of them flexible: ced's modal analysis (beams, joint
   coordinates, a ternary link carrying E) against the eigenvalues of Exudyn's constrained
   system.
3. **Peak strains, lightly damped.** The four-bar's coupler flexible; two binary links of a
   six-bar (the Watt II's coupler B→C and coupler2 E→F, the Stephenson III's rocker D→C and
   coupler2 E→F); the others rigid;
   stiffness-proportional damping β = :data:`BETA`
   (Rayleigh βK in ced, Kelvin–Voigt on the cables' strain rates in Exudyn: 0.18 % of
   critical at the first mode, 57 Hz, 8 % at 2.5 kHz), so that the peak is the low modes'
   and both codes are converged in time at 8192 steps a revolution. The peak outer-fibre
   bending strain of each flexible link over time and 21 stations: ced's linear KED
   (Euler–Bernoulli beams in the moving frames) against Exudyn's geometrically exact ANCF
   cables. The peer's strain at a node is an element's end curvature, which converges more
   slowly than ced's recovery: it runs :data:`PEER_ELEMENTS` elements. ced twice: with its
   default geometric stiffness (the rigid motion's axial forces) and with the effect
   ``elastic_axial_force`` (the elastic response's own axial force too,
   :mod:`ced.response.axial_force`), reported side by side. A peak is one sample of a
   history whose phase moves it; the RMS difference of each link's strain history at the
   peer's peak station (:data:`RECORD` samples over the run, relative to the peak) is
   reported beside it.
4. **Peak strains, undamped**, each code at two time steps. The undeformed start rings in
   every mode of the links; the Watt II's coupler2 carries a 1.5–4 kHz ripple on its peak,
   and where its crest falls moves the peak by a few per cent with the step in both codes:
   reported, not held to a tolerance. (The four-bar's undamped sweep is the peer benchmark's
   problem: every speed of it, 90–110 rad/s, is flagged ``large_deflection`` by ced.)

Both codes start from the same geometry: the peer's model (``exudyn_linkage.py``, run in the
peer venv) is written from ced's rigid state at t = 0 (joint positions, link angles and the
rigid velocity field) and ced's body properties; everything after t = 0 each code computes on
its own. Results go to ``benchmarks/peer_linkages.json``; the run fails (exit 1) where the
rigid results differ by more than :data:`RIGID_TOLERANCE`, a frequency by more than
:data:`FREQUENCY_TOLERANCE`, or a damped peak strain of a case ced does not flag by more than
:data:`STRAIN_TOLERANCE`.

Run ``.venv/bin/python benchmarks/peer/linkages.py`` (installs the peer on first use; about
twelve minutes).
"""
from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import compare  # noqa: E402  (benchmarks/peer/compare.py: the peer venv)

import ced  # noqa: E402
from ced.problem.scene import load_scene  # noqa: E402
from ced.problem.status import status_names  # noqa: E402
from ced.response.batch import make_batch  # noqa: E402

RESULTS = HERE.parent / "peer_linkages.json"
PEER_SCRIPT = HERE / "exudyn_linkage.py"


class Linkage(NamedTuple):
    """A linkage of the comparison: its mechanism block, its flexible links and the input
    speeds (rad/s) of its damped and undamped runs."""

    mechanism: dict
    flexible: tuple
    damped_speeds: tuple
    undamped_speeds: tuple


#: The damped runs' speeds: two below ced's ``large_deflection`` (1 % of a link's length),
#: the others flagged (the four-bar at 90–110 rad/s ``large_deflection``, at 90 also
#: ``resonant``; the Watt II at 90 ``large_deflection`` and ``resonant``, the Stephenson III
#: ``large_deflection``).
LINKAGES = {
    "four_bar": Linkage({"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                         "rocker": 0.35}, ("coupler",), (20.0, 50.0, 90.0, 110.0),
                        (90.0, 110.0)),
    "watt_ii": Linkage({"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                        "rocker": 0.35, "rocker_arm": 0.25, "rocker_arm_angle": 2.5,
                        "coupler2": 0.4, "rocker2": 0.3, "pivot2_x": 0.2, "pivot2_y": -0.3},
                       ("coupler", "coupler2"), (20.0, 50.0, 90.0), (50.0, 90.0)),
    "stephenson_iii": Linkage({"type": "stephenson_iii", "ground": 0.5, "crank": 0.1,
                               "coupler": 0.45, "rocker": 0.35, "coupler_arm": 0.3,
                               "coupler_arm_angle": 0.6, "coupler2": 0.4, "rocker2": 0.3,
                               "pivot2_x": 0.4, "pivot2_y": 0.55},
                              ("rocker", "coupler2"), (20.0, 50.0, 90.0), (50.0, 90.0)),
}
SECTION = {"shape": "rectangle", "height": 0.005, "width": 0.01}
#: Input speeds of the rigid comparison, rad/s.
RIGID_SPEEDS = (50.0, 90.0)
RIGID_STEPS = 4096
#: Stiffness-proportional damping of the damped comparison, s.
BETA = 1e-5
#: (elements, steps per revolution) of ced's damped runs (converged: 32 elements or 16,384
#: steps move its peaks by at most 0.04 %) and the peer's elements.
CED_DAMPED = (16, 8192)
PEER_ELEMENTS = 32
#: (elements, steps per revolution) of the undamped comparison.
UNDAMPED_SETTINGS = ((16, 8192), (16, 16384))
#: Frequencies compared per flexible set.
MODES = 8
#: Samples of the force histories compared.
RECORD = 256
#: Fraction of a revolution after the start whose samples are reported apart (module
#: docstring).
START_UP = 1.0 / 16.0
#: Largest difference of the rigid histories allowed after :data:`START_UP`, relative to each
#: history's largest value (the peer's generalized-α accelerations at 4096 steps a
#: revolution, O(h²), and its Newton tolerance).
RIGID_TOLERANCE = 1e-4
#: Largest relative difference of a natural frequency allowed (both are 16-element models of
#: the same beams; ANCF and Hermite elements differ in the higher modes).
FREQUENCY_TOLERANCE = 1e-3
#: Largest relative difference of a damped peak coupler strain allowed where ced flags
#: nothing: geometric nonlinearity (the peer) against the linear KED (ced), which grows with
#: the deflection that ``large_deflection`` bounds at 1 % of a link's length.
STRAIN_TOLERANCE = 0.02


def scene(mechanism: dict, speed: float, flexible: tuple, elements: int = 16,
          steps: int = RIGID_STEPS, beta: float = 0.0, second_order: bool = False) -> dict:
    """ced's scene: ``mechanism`` at ``speed`` rad/s, ``flexible`` links flexible, Rayleigh
    damping βK (``beta``, s) where it is not zero; with ``second_order`` the effect
    ``elastic_axial_force`` too."""
    links = {"default": {"material": "steel", "section": SECTION, "flexible": False},
             **{name: {"flexible": True} for name in flexible}}
    damping = {}
    if beta:
        damping = {"effects": ["inertia", "elastic_inertia", "coriolis", "centrifugal",
                               "axial_stiffening", "damping"],
                   "damping": {"model": "rayleigh", "beta": beta}}
    if second_order:
        effects = damping.get("effects", ["inertia", "elastic_inertia", "coriolis",
                                          "centrifugal", "axial_stiffening"])
        damping["effects"] = effects + ["elastic_axial_force"]
    return {**damping, "mechanism": mechanism, "links": links, "drive": {"speed": float(speed)},
            "discretization": ({"elements_per_link": elements} if flexible
                               else {"formulation": "rigid"}),
            "time": {"revolutions": 2, "steps_per_revolution": steps, "start": "undeformed"},
            "outputs": {"stations": 21, "error_estimate": False}}


def linkage(mechanism: dict, flexible: tuple, beta: float = 0.0) -> dict:
    """The peer's description (``exudyn_linkage.py``) from ced's rigid state at t = 0, at
    unit input speed, and ced's body properties; ``beta`` (s) its links' Kelvin–Voigt
    damping, Rayleigh's βK."""
    normalized = load_scene(scene(mechanism, 1.0, flexible))
    batch = make_batch([normalized])
    motion = batch.rigid_motion(np.zeros((1, 1)))
    topology = batch.topology
    joint_names = list(topology.joint_names)
    position = motion.joint_position[0, 0]
    velocity = motion.joint_velocity[0, 0] / batch.speed[0]
    material = normalized["links"]["crank"]["material"]
    section = normalized["links"]["crank"]["section"]
    out = {"input": topology.input_link, "material": {"E": material["E"], "rho": material["rho"]},
           "section": {"area": section["area"], "second_moment": section["second_moment"],
                       "height": section["height"]},
           "joints": {}, "links": {}, "damping_beta": beta}
    for j, (first, second) in topology.joints.items():
        k = joint_names.index(j)
        out["joints"][j] = {"bodies": [first, second], "position": position[k].tolist(),
                            "velocity": velocity[k].tolist()}
    bodies = batch.bodies
    for i, (name, (P, Q)) in enumerate(topology.links.items()):
        theta = float(motion.link_angle[0, 0, i])
        c, s = np.cos(theta), np.sin(theta)
        to_link = np.array([[c, s], [-s, c]])
        on_link = [j for j, pair in topology.joints.items() if name in pair]
        points = {j: (to_link @ (position[joint_names.index(j)]
                                 - position[joint_names.index(P)])).tolist() for j in on_link}
        out["links"][name] = {
            "joints": [P, Q], "flexible": name in flexible,
            "length": float(batch.link_lengths[0, i]), "angle": theta,
            "angular_velocity": float(motion.link_angular_velocity[0, 0, i] / batch.speed[0]),
            "mass": float(bodies.mass[0, i]), "inertia": float(bodies.inertia[0, i]),
            "centre": ([0.5 * float(batch.link_lengths[0, i]), 0.0] if bodies.centre is None
                       else bodies.centre[0, i].tolist()),  # None: every link a uniform bar
            "points": points}
    return out


def run_peer(description: dict, elements: int, steps: int, speeds, timeout: float = 1800.0
             ) -> dict:
    """The peer's results (``exudyn_linkage.py``'s JSON) for ``description``."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "linkage.json"
        path.write_text(json.dumps(description))
        cmd = [str(compare.PEER_PYTHON), str(PEER_SCRIPT), str(path), "--elements",
               str(elements), "--steps", str(steps), "--record", str(RECORD), "--speeds",
               *map(str, speeds)]
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if done.returncode:
        raise RuntimeError(f"peer failed ({done.returncode}): {done.stderr[-2000:]}")
    return json.loads(done.stdout)


def rigid_check(link: Linkage, speeds=RIGID_SPEEDS) -> dict:
    """Input torque and joint force magnitudes, ced against the peer, every link rigid."""
    peer = run_peer(linkage(link.mechanism, ()), 1, RIGID_STEPS, speeds)
    ds = ced.simulate([scene(link.mechanism, w, ()) for w in speeds])
    names = [str(j) for j in ds["joint"].values]
    rows = []
    for i, case in enumerate(peer["cases"]):
        t = np.asarray(case["time"])
        h = float(ds["time"][i, 1])
        steps = np.rint(t / h).astype(int)
        assert np.allclose(steps * h, t, rtol=0, atol=1e-9 * t[-1]), "peer samples off ced's steps"
        settled = t >= START_UP * 2.0 * np.pi / case["speed"]
        row = {"speed": case["speed"], "samples": len(t)}

        def difference(mine, theirs):
            scale = np.abs(mine).max()
            d = np.abs(mine - theirs) / scale
            return {"max_ced": float(scale), "relative_difference": float(d[settled].max()),
                    "median": float(np.median(d)), "start_up": float(d[~settled].max())}

        torque = np.asarray(ds["input_torque"][i, steps])
        theirs = np.asarray(case["input_torque"])
        # The peer's multiplier is the generalized force of the crank's angle constraint, ced's
        # the drive's torque on the crank: the same up to the sign of the convention.
        sign = 1.0 if np.dot(torque, theirs) >= 0 else -1.0
        row["input_torque"] = {"sign": sign, **difference(torque, sign * theirs)}
        force = np.hypot(*np.moveaxis(np.asarray(ds["joint_force"][i, steps]), -1, 0))
        row["joint_force"] = {j: difference(force[:, names.index(j)], np.asarray(magnitude))
                              for j, magnitude in case["joint_force_magnitude"].items()}
        row["worst"] = max([row["input_torque"]["relative_difference"]]
                           + [v["relative_difference"] for v in row["joint_force"].values()])
        rows.append(row)
    return {"steps_per_revolution": RIGID_STEPS, "cases": rows,
            "worst": max(r["worst"] for r in rows), "tolerance": RIGID_TOLERANCE}


def ced_peaks(link: Linkage, speeds, elements: int, steps: int, beta: float = 0.0,
              second_order: bool = False) -> list[dict]:
    """ced's peak outer-fibre bending strain of each flexible link, where it is, and the
    case's status; with its signed bending strain (time, station) per link, ``history``."""
    ds = ced.simulate([scene(link.mechanism, w, link.flexible, elements, steps, beta,
                             second_order) for w in speeds])
    links = [str(x) for x in ds["link"].values]
    out = []
    for i in range(len(speeds)):
        peaks, history = {}, {}
        for name in link.flexible:
            history[name] = np.asarray(ds["bending_strain"][i, :, links.index(name)], float)
            strain = np.abs(history[name])
            it, js = np.unravel_index(np.argmax(strain), strain.shape)
            peaks[name] = {"value": float(strain.max()), "time": float(ds["time"][i, it]),
                           "station": float(ds["station"][js])}
        out.append({"speed": float(speeds[i]), "peak_strain": peaks,
                    "status": int(ds["status"][i]), "history": history,
                    "time": np.asarray(ds["time"][i], float),
                    "station": np.asarray(ds["station"], float)})
    return out


def history_difference(mine: dict, theirs: dict, name: str) -> float:
    """RMS difference of ``name``'s signed bending strain over the run, ced's (``mine``, of
    :func:`ced_peaks`) against the peer's (``theirs``) at the peer's recorded times and at the
    station of its peak, relative to the peer's peak: the whole history, where a peak is one
    sample of it."""
    t = np.asarray(theirs["time"])
    k = np.rint(t / mine["time"][1]).astype(int)
    js = int(np.argmin(np.abs(mine["station"] - theirs["peak_strain"][name]["station"])))
    d = mine["history"][name][k, js] - np.asarray(theirs["strain_history"][name])
    return float(np.sqrt(np.mean(d * d)) / theirs["peak_strain"][name]["value"])


def frequency_check(link: Linkage) -> dict:
    """The :data:`MODES` lowest natural frequencies of the frozen linkage (t = 0, at rest),
    ced against the peer, with each flexible link alone and both flexible."""
    rows = []
    for flexible in dict.fromkeys([(name,) for name in link.flexible] + [link.flexible]):
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "linkage.json"
            path.write_text(json.dumps(linkage(link.mechanism, flexible)))
            done = subprocess.run([str(compare.PEER_PYTHON), str(PEER_SCRIPT), str(path),
                                   "--elements", "16", "--frequencies", str(MODES)],
                                  capture_output=True, text=True, timeout=900)
        if done.returncode:
            raise RuntimeError(f"peer failed ({done.returncode}): {done.stderr[-2000:]}")
        theirs = np.array(json.loads(done.stdout)["frequencies"])
        frozen = scene(link.mechanism, 1e-6, flexible, 16, 256)  # at rest: no speed effects
        frozen["modal"] = {"modes": MODES, "angles": 4}
        mine = ced.simulate(frozen)["natural_frequency"].values[0, 0]  # modal angle 0
        rows.append({"flexible": list(flexible), "ced_hz": mine.tolist(),
                     "peer_hz": theirs.tolist(),
                     "worst": float(np.abs(mine / theirs - 1.0).max())})
    return {"elements": 16, "cases": rows, "worst": max(r["worst"] for r in rows),
            "tolerance": FREQUENCY_TOLERANCE}


def damped_check(link: Linkage) -> dict:
    """Peak strain of each flexible link, lightly damped, ced against the peer."""
    elements, steps = CED_DAMPED
    speeds = link.damped_speeds
    mine = ced_peaks(link, speeds, elements, steps, BETA)
    second = ced_peaks(link, speeds, elements, steps, BETA, second_order=True)
    theirs = run_peer(linkage(link.mechanism, link.flexible, BETA), PEER_ELEMENTS, steps,
                      speeds)["cases"]
    rows = []
    for a, a2, b in zip(mine, second, theirs):
        row = {"speed": a["speed"], "status_ced": a["status"],
               "flags_ced": status_names(a["status"]),
               "flags_ced_second_order": status_names(a2["status"])}
        for name in link.flexible:
            x, x2, y = a["peak_strain"][name], a2["peak_strain"][name], b["peak_strain"][name]
            row[name] = {"ced": x, "ced_second_order": x2, "peer": y,
                         "ced_over_peer_minus_1": x["value"] / y["value"] - 1.0,
                         "second_order_over_peer_minus_1": x2["value"] / y["value"] - 1.0,
                         "history_rms_difference": history_difference(a, b, name),
                         "second_order_history_rms_difference":
                             history_difference(a2, b, name)}
        rows.append(row)
    held = [abs(r[n]["ced_over_peer_minus_1"]) for r in rows if r["status_ced"] == 0
            for n in link.flexible]
    return {"beta": BETA, "ced_setting": list(CED_DAMPED),
            "peer_setting": [PEER_ELEMENTS, steps], "cases": rows,
            "worst_unflagged": max(held) if held else None, "tolerance": STRAIN_TOLERANCE}


def undamped_check(link: Linkage) -> dict:
    """Peak strain of each flexible link, undamped, ced against the peer, each at two
    steps."""
    description = linkage(link.mechanism, link.flexible)
    speeds = link.undamped_speeds
    runs = {"ced": {}, "peer": {}}
    for elements, steps in UNDAMPED_SETTINGS:
        key = f"{elements}/{steps}"
        runs["ced"][key] = ced_peaks(link, speeds, elements, steps)
        runs["peer"][key] = run_peer(description, elements, steps, speeds)["cases"]
    rows = []
    for i, w in enumerate(speeds):
        row = {"speed": w, "flags_ced": status_names(runs["ced"][key][i]["status"])}
        for name in link.flexible:
            row[name] = {setting: {code: runs[code][setting][i]["peak_strain"][name]["value"]
                                   for code in runs} for setting in runs["ced"]}
        rows.append(row)
    return {"settings": [list(s) for s in UNDAMPED_SETTINGS], "cases": rows}


def compare_linkage(link: Linkage) -> dict:
    """Every comparison of the module docstring for ``link``, printed as it comes."""
    rigid = rigid_check(link)
    print(f"  rigid: largest relative difference {rigid['worst']:.2e}", flush=True)
    frequencies = frequency_check(link)
    print(f"  frequencies: largest relative difference {frequencies['worst']:.2e}", flush=True)
    damped = damped_check(link)
    for row in damped["cases"]:
        print(f"  damped {row['speed']:5.1f} rad/s {','.join(row['flags_ced'])}: "
              + ", ".join(f"{n} {100 * row[n]['ced_over_peer_minus_1']:+.2f} % "
                          f"({100 * row[n]['second_order_over_peer_minus_1']:+.2f} % with "
                          f"elastic_axial_force), history rms "
                          f"{100 * row[n]['history_rms_difference']:.2f} % "
                          f"({100 * row[n]['second_order_history_rms_difference']:.2f} %)"
                          for n in link.flexible), flush=True)
    undamped = undamped_check(link)
    return {"mechanism": link.mechanism, "flexible": list(link.flexible), "rigid": rigid,
            "frequencies": frequencies, "damped": damped, "undamped": undamped}


def agree(result: dict) -> bool:
    """Whether a linkage's comparisons are within the module's tolerances."""
    worst = result["damped"]["worst_unflagged"]
    return (result["rigid"]["worst"] <= RIGID_TOLERANCE
            and result["frequencies"]["worst"] <= FREQUENCY_TOLERANCE
            and worst is not None and worst <= STRAIN_TOLERANCE)


def main(argv=None) -> int:
    argparse.ArgumentParser(description=__doc__.split("\n")[0]).parse_args(argv)
    version = compare.setup_peer()
    started = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    results = {}
    for name, link in LINKAGES.items():
        print(name, flush=True)
        results[name] = compare_linkage(link)
    out = {"what": __doc__.split("\n")[0],
           "command": ".venv/bin/python benchmarks/peer/linkages.py", "started": started,
           "exudyn": version, "python": platform.python_version(), "section": SECTION,
           "tolerances": {"rigid": RIGID_TOLERANCE, "frequency": FREQUENCY_TOLERANCE,
                          "damped_strain_unflagged": STRAIN_TOLERANCE},
           **results}
    RESULTS.write_text(json.dumps(out, indent=1) + "\n")
    ok = True
    for name, result in results.items():
        ok &= agree(result)
        print(f"{name}: {'agree' if agree(result) else 'DISAGREE'}: rigid "
              f"{result['rigid']['worst']:.1e} (<= {RIGID_TOLERANCE}), frequencies "
              f"{result['frequencies']['worst']:.1e} (<= {FREQUENCY_TOLERANCE}), damped peak "
              f"strains {100 * result['damped']['worst_unflagged']:.2f} % "
              f"(<= {100 * STRAIN_TOLERANCE:.0f} %) where ced flags nothing")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
