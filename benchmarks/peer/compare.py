"""Peer benchmark: Exudyn's cheapest 1 %-accurate setting on the reference flexible four-bar.

Run from the repository root, in ced's venv (one command; installs the peer on first use):

    .venv/bin/python benchmarks/peer/compare.py            # full run: ~35 min (loaded 2 cores)
    .venv/bin/python benchmarks/peer/compare.py --quick    # 11 speeds, a smoke test

What it does
------------
1. Creates ``benchmarks/.peer-venv`` (gitignored) and installs Exudyn and numpy from PyPI into
   it (``benchmarks/peer/setup_peer.sh``); Exudyn is not a dependency of ced. Exits 1 with a
   one-line message if that fails.
2. The problem (``exudyn_four_bar.py``, which runs in the peer venv): the reference four-bar of
   ced (ground 0.5, crank 0.1, coupler 0.45, rocker 0.35 m; steel; 10 × 5 mm section, 5 mm in
   plane; rigid crank and rocker, flexible coupler; no gravity, no damping), crank at constant Ω
   from an undeformed start, two revolutions; output the peak outer-fibre bending strain
   (h/2)|κ| of the coupler over time and 21 stations; solver time = wall time of Exudyn's
   ``SolveDynamic`` (one thread), not model building.
3. Sweep: 100 speeds, Ω = linspace(90, 110, 100) rad/s. Each setting (elements, steps per
   revolution) runs the whole sweep in one subprocess of the peer venv that prints JSON.
4. Reference: ``REFERENCE`` (16 elements, 8192 steps per revolution) at all 100 speeds; that it
   is converged is shown by two refinements (32 elements and 16384 steps; 16 elements and
   16384 steps) at ``CHECK_SPEEDS``.
5. Search: every (elements, steps) of ``ELEMENTS`` × ``STEPS`` at all 100 speeds; a setting
   passes when its peak strain is within 1 % of the reference at every speed; the cheapest is
   the passing one with the least total solver time over the sweep. Its timing is repeated.
6. Cross-check (needs ced, i.e. ced's venv): converged peak strain of ced (16 and 32
   elements, 8192 steps per revolution, ``start: undeformed``) against the peer's reference at
   CHECK_SPEEDS.
7. Writes ``benchmarks/peer_results.json``.

Result of the committed run (exudyn 1.13.6, load average 4-7 on 2 cores, so times are inflated
and noisy): cheapest setting 16 elements × 1257 steps per revolution, max error 0.59 %,
0.36 s solver time per case (best of 2); 8 elements never pass (element error ≈ 1 %); the
reference agrees with 32 × 16384 to 0.08 % and with 16 × 16384 to 0.25 %. ced vs Exudyn,
converged: +2.0 % (90 rad/s), −0.4 % (99.9), +1.5 % (110); 0.2–0.6 % at 30–70 rad/s.

The peer part is :func:`peer_sweep` (one setting, a list of speeds → per-speed peak strain and
solver seconds) and :func:`peer_search`; :func:`ced_cross_check` is the only part that imports
ced.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
PEER_VENV = HERE.parent / ".peer-venv"
PEER_PYTHON = PEER_VENV / "bin" / "python"
PEER_SCRIPT = HERE / "exudyn_four_bar.py"
RESULTS = HERE.parent / "peer_results.json"
CACHE = HERE.parent / ".peer-cache"  # gitignored: one JSON per (setting, speeds) sweep

SPEEDS = np.linspace(90.0, 110.0, 100)
TOLERANCE = 0.01
REFERENCE = (16, 8192)  # elements, steps per revolution
REFINEMENTS = ((32, 16384), (16, 16384))
CHECK_SPEEDS = (90.0, 100.0, 110.0)
ELEMENTS = (4, 8, 12, 16)
STEPS = (256, 512, 768, 1024, 1257, 1536, 2048, 3072, 4096)


class PeerError(RuntimeError):
    """The peer cannot be installed or run."""


def setup_peer() -> str:
    """Create the peer venv and install Exudyn into it; return Exudyn's version."""
    proc = subprocess.run(["bash", str(HERE / "setup_peer.sh"), sys.executable],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise PeerError("cannot install Exudyn into benchmarks/.peer-venv: "
                        + (proc.stderr.strip().splitlines() or ["(no message)"])[-1])
    return proc.stdout.strip().split()[-1]


_USE_CACHE = True


def peer_sweep(speeds, elements: int, steps: int, drive: str = "velocity",
               cached: bool = True, revolutions: int = 2, damping_beta: float = 0.0) -> dict:
    """Run the Exudyn model at ``speeds`` with one setting, in the peer venv.

    Returns the peer's JSON: ``cases`` is a list of {speed, peak_strain, solver_seconds, ...}
    in the order of ``speeds`` (with more than two ``revolutions``, also each revolution's
    peak). ``damping_beta`` (s): stiffness-proportional damping of the coupler. A sweep already
    run (same setting, speeds and peer script) is read from ``benchmarks/.peer-cache`` unless
    ``cached`` is False or ``--fresh`` was given.
    """
    import hashlib  # noqa: PLC0415

    key = hashlib.sha256(json.dumps([PEER_SCRIPT.read_text(), elements, steps, drive,
                                     [float(x) for x in speeds], revolutions,
                                     damping_beta]).encode()).hexdigest()[:16]
    path = CACHE / f"{elements}x{steps}-{drive}-{len(speeds)}-{key}.json"
    if cached and _USE_CACHE and path.exists():
        return json.loads(path.read_text())
    run = _peer_sweep(speeds, elements, steps, drive, revolutions, damping_beta)
    CACHE.mkdir(exist_ok=True)
    path.write_text(json.dumps(run))
    return run


def _peer_sweep(speeds, elements: int, steps: int, drive: str, revolutions: int = 2,
                damping_beta: float = 0.0) -> dict:
    if not PEER_PYTHON.exists():
        raise PeerError(f"no peer venv at {PEER_VENV}; run benchmarks/peer/setup_peer.sh")
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump([float(x) for x in speeds], f)
        path = f.name
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    try:
        proc = subprocess.run(
            [str(PEER_PYTHON), str(PEER_SCRIPT), "--elements", str(elements), "--steps",
             str(steps), "--drive", drive, "--speeds-json", path, "--revolutions",
             str(revolutions), "--damping-beta", repr(float(damping_beta))],
            capture_output=True, text=True, env=env)
    finally:
        os.unlink(path)
    if proc.returncode != 0:
        tail = "\n".join(proc.stderr.strip().splitlines()[-5:])
        raise PeerError(f"Exudyn run ({elements} elements, {steps} steps) failed:\n{tail}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _peaks(run: dict) -> np.ndarray:
    return np.array([c["peak_strain"] for c in run["cases"]])


def _seconds(run: dict) -> np.ndarray:
    return np.array([c["solver_seconds"] for c in run["cases"]])


def _log(msg: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def setting_record(run: dict, reference: np.ndarray) -> dict:
    err = np.abs(_peaks(run) / reference - 1.0)
    sec = _seconds(run)
    return {"elements": run["elements"], "steps_per_revolution": run["steps_per_revolution"],
            "max_rel_error": float(err.max()), "p95_rel_error": float(np.percentile(err, 95)),
            "worst_speed": float(run["cases"][int(err.argmax())]["speed"]),
            "passes": bool(err.max() <= TOLERANCE),
            "peak_strain": _peaks(run).tolist(),
            "mean_solver_seconds": float(sec.mean()),
            "median_solver_seconds": float(np.median(sec)),
            "total_solver_seconds": float(sec.sum())}


def peer_search(speeds=SPEEDS, elements=ELEMENTS, steps=STEPS, reference=REFERENCE,
                refinements=REFINEMENTS, check_speeds=CHECK_SPEEDS) -> dict:
    """Reference sweep, its convergence check, and the cheapest 1 %-setting of the peer."""
    speeds = [float(x) for x in speeds]
    _log(f"peer reference {reference} at {len(speeds)} speeds")
    t0 = time.perf_counter()
    ref_run = peer_sweep(speeds, *reference)
    ref_wall = time.perf_counter() - t0
    ref = _peaks(ref_run)
    # Convergence of the reference: two refinements at a few speeds.
    idx = [int(np.argmin(np.abs(np.array(speeds) - s))) for s in check_speeds]
    chk_speeds = [speeds[i] for i in idx]
    convergence = []
    for setting in refinements:
        _log(f"peer refinement {setting} at {chk_speeds}")
        fine = _peaks(peer_sweep(chk_speeds, *setting))
        convergence.append({"elements": setting[0], "steps_per_revolution": setting[1],
                            "speeds": chk_speeds, "peak_strain": fine.tolist(),
                            "reference_peak_strain": ref[idx].tolist(),
                            "rel_diff": (ref[idx] / fine - 1.0).tolist()})
    settings, runs = [], {}
    for ne in elements:
        for ns in steps:
            _log(f"peer setting {ne} elements, {ns} steps")
            run = peer_sweep(speeds, ne, ns)
            runs[(ne, ns)] = run
            rec = setting_record(run, ref)
            settings.append(rec)
            _log(f"  max err {rec['max_rel_error']:.4f}, p95 {rec['p95_rel_error']:.4f}, "
                 f"mean {rec['mean_solver_seconds']:.3f} s/case")
    passing = sorted((s for s in settings if s["passes"]),
                     key=lambda s: s["total_solver_seconds"])
    chosen = None
    if passing:
        # The machine is shared: re-time the cheapest candidates once more and take, per
        # case, the lower of the two solver times (best of 2), then rank by that total.
        for s in passing[:3]:
            ne, ns = s["elements"], s["steps_per_revolution"]
            _log(f"re-timing {ne} elements, {ns} steps")
            again = peer_sweep(speeds, ne, ns, cached=False)
            best = np.minimum(_seconds(runs[(ne, ns)]), _seconds(again))
            s["retimed_total_solver_seconds"] = float(_seconds(again).sum())
            s["best_of_2_total_solver_seconds"] = float(best.sum())
            s["best_of_2_mean_solver_seconds"] = float(best.mean())
            s["retimed_max_rel_error"] = float(np.abs(_peaks(again) / ref - 1.0).max())
        head = sorted(passing[:3], key=lambda s: s["best_of_2_total_solver_seconds"])
        chosen = {k: v for k, v in head[0].items() if k != "peak_strain"}
        chosen["mean_solver_seconds_per_case"] = chosen["best_of_2_mean_solver_seconds"]
    return {
        "reference": {"elements": reference[0], "steps_per_revolution": reference[1],
                      "speeds": speeds, "peak_strain": ref.tolist(),
                      "solver_seconds": _seconds(ref_run).tolist(),
                      "wall_seconds_whole_sweep": ref_wall},
        "reference_setting": list(reference),
        "reference_convergence": convergence,
        "settings": settings,
        "chosen": chosen,
        "check_speeds": chk_speeds,
        "exudyn": ref_run["exudyn"],
        "peer_python": ref_run["python"],
    }


CED_SETTINGS = ((16, 8192), (32, 8192))
#: Low speeds (small deflections, far from resonance): where a linearized and a geometrically
#: exact model must agree closely.
LOW_SPEEDS = (30.0, 50.0, 70.0)


def ced_cross_check(speeds=CHECK_SPEEDS, settings=CED_SETTINGS) -> list:
    """ced's converged peak coupler strain at ``speeds`` (imports ced; run in ced's venv)."""
    import ced  # noqa: PLC0415

    out = []
    for (elements, steps), speed in ((s, w) for s in settings for w in speeds):
        scene = {
            "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                          "rocker": 0.35},
            "links": {"default": {"material": "steel", "section": {
                "shape": "rectangle", "height": 0.005, "width": 0.01}},
                "crank": {"flexible": False}, "rocker": {"flexible": False}},
            "drive": {"speed": float(speed)},
            "discretization": {"elements_per_link": elements},
            "time": {"revolutions": 2, "steps_per_revolution": steps, "start": "undeformed"},
            "outputs": {"stations": 21, "error_estimate": False},
        }
        ds = ced.simulate(scene)
        strain = np.abs(np.asarray(ds["bending_strain"]))[0, :, 1]
        it, js = np.unravel_index(np.argmax(strain), strain.shape)
        out.append({"speed": float(speed), "elements": elements, "steps_per_revolution": steps,
                    "peak_strain": float(strain.max()),
                    "peak_time": float(np.asarray(ds["time"])[0, it]),
                    "peak_station": float(np.asarray(ds["station"])[js])})
    return out


def machine() -> dict:
    cpu = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"platform": platform.platform(), "cpu": cpu, "cores": os.cpu_count(),
            "load_average_at_start": list(os.getloadavg()),
            "note": "shared machine; solver times are single-threaded wall times"}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true",
                   help="11 speeds and a small grid (smoke test; does not write results)")
    p.add_argument("--no-ced", action="store_true", help="skip the cross-check with ced")
    p.add_argument("--output", default=str(RESULTS))
    p.add_argument("--fresh", action="store_true", help="ignore benchmarks/.peer-cache")
    args = p.parse_args(argv)
    global _USE_CACHE
    _USE_CACHE = not args.fresh
    started = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    mach = machine()
    try:
        version = setup_peer()
        _log(f"exudyn {version} in {PEER_VENV}")
        if args.quick:
            result = peer_search(speeds=np.linspace(90, 110, 11), elements=(8,),
                                 steps=(512, 1024), reference=(8, 4096),
                                 refinements=((16, 4096),), check_speeds=(100.0,))
        else:
            result = peer_search()
    except PeerError as exc:
        print(f"compare: {exc}", file=sys.stderr)
        return 1
    cross = None
    if not args.no_ced:
        # Same speeds for both codes: the sweep's speeds nearest CHECK_SPEEDS (100 rad/s is not
        # in linspace(90, 110, 100)), and LOW_SPEEDS with the peer at its reference setting.
        speeds = list(result["check_speeds"]) + ([] if args.quick else list(LOW_SPEEDS))
        peer_ref = dict(zip(result["reference"]["speeds"], result["reference"]["peak_strain"]))
        low = [] if args.quick else list(LOW_SPEEDS)
        if low:
            run = peer_sweep(low, *result["reference_setting"])
            peer_ref.update({c["speed"]: c["peak_strain"] for c in run["cases"]})
        _log(f"ced cross-check at {speeds}")
        cross = ced_cross_check(speeds)
        for c in cross:
            c["ced_setting"] = [c["elements"], c["steps_per_revolution"]]
            c["peer_setting"] = list(result["reference_setting"])
            c["peer_peak_strain"] = peer_ref[c["speed"]]
            c["ced_over_peer_minus_1"] = c["peak_strain"] / peer_ref[c["speed"]] - 1.0
            _log(f"  {c['speed']:.3f} rad/s: ced {c['ced_setting']} {c['peak_strain']:.5e}, "
                 f"exudyn {c['peer_peak_strain']:.5e}, "
                 f"diff {100 * c['ced_over_peer_minus_1']:+.2f} %")
    doc = {
        "what": "Exudyn (peer) on ced's reference flexible four-bar: cheapest setting whose "
                "peak coupler strain is within 1 % of the peer's converged value at each of "
                "100 speeds",
        "command": ".venv/bin/python benchmarks/peer/compare.py",
        "started": started,
        "exudyn": result.pop("exudyn"),
        "peer_python": result.pop("peer_python"),
        "driver_python": platform.python_version(),
        "machine": mach,
        "problem": {
            "mechanism": {"ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35,
                          "initial_crank_angle": 0.0, "branch": "open"},
            "material": "steel E = 210 GPa, rho = 7850 kg/m3",
            "section": "rectangle 10 mm out of plane x 5 mm in plane",
            "links": "crank and rocker rigid (slender-bar mass and inertia), coupler flexible",
            "joints": "pins at the joint centres, coupler pinned at its end nodes",
            "drive": "constant crank speed from t = 0",
            "start": "undeformed: rigid positions and rigid velocity field at t = 0",
            "revolutions": 2, "gravity": 0, "damping": 0,
            "output": "max over time and 21 stations of (h/2)|curvature| on the coupler",
            "speeds": "numpy.linspace(90, 110, 100) rad/s",
        },
        "peer_model": {
            "coupler": "ObjectANCFCable2D (geometrically exact planar Euler-Bernoulli ANCF "
                       "cable), NodePoint2DSlope1 nodes",
            "crank_rocker": "NodeRigidBody2D + ObjectRigidBody2D at the centre of mass",
            "joints": "ObjectJointRevolute2D (ground-crank, crank-coupler end node, coupler end "
                      "node-rocker, rocker-ground)",
            "drive": "ObjectConnectorCoordinate on the crank angle at velocity level "
                     "(offset = Omega): theta(t) = Omega t to 1e-12 rad; a position-level "
                     "Python user-function variant gives the same peaks to 1e-9",
            "integrator": "generalized-alpha, index 3, spectral radius 0.9, fixed step, "
                          "Newton relTol 1e-8, absTol 1e-10 (1e-9 and 1e-7 change peaks by "
                          "< 1e-7 relative)",
            "solver_time": "wall time of exudyn.SolveDynamic only, one thread",
        },
        "tolerance": TOLERANCE,
        **result,
        "ced_cross_check": cross,
        "load_average_at_end": list(os.getloadavg()),
    }
    if args.quick:
        print(json.dumps(doc, indent=1))
        return 0
    Path(args.output).write_text(json.dumps(doc, indent=1) + "\n")
    _log(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
