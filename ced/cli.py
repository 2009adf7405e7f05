"""Command line: ``ced run SCENE.yaml -o OUT.nc``, ``ced check CONFIG.yaml``,
``ced classify --ground … --rocker …``, ``ced ladder SCENE.yaml -o DIR``.

Bad input exits with code 2 and a message naming the key path; nothing is written.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

__all__ = ["main"]


def _run(args: argparse.Namespace) -> int:
    from .io import check_output, write_dataset
    from .problem.errors import SceneError
    from .problem.scene import load_scene
    from .problem.status import status_names
    from .simulation.simulate import simulate

    check_output(args.output, inputs=args.scenes)  # before any work
    scenes = []
    for path in args.scenes:  # validate everything before solving
        try:
            scenes.append(load_scene(path))
        except SceneError as err:
            if len(args.scenes) == 1:
                raise
            raise SceneError(err.path, f"{err.message} (in {path})") from None
    ds = simulate(scenes)
    try:
        write_dataset(ds, args.output)
    except (OSError, RuntimeError) as err:  # disk full, permissions, HDF5 errors
        raise SceneError("output", f"cannot write {args.output!r}: {err}") from None
    for case in range(ds.sizes["case"]):
        flags = ",".join(status_names(int(ds.status.values[case])))
        print(f"case {case}: {ds.family.values[case]} status={flags} "
              f"solve_time={float(ds.solve_time.values[case]):.3g} s")
    print(f"wrote {args.output}")
    return 0


def _check(args: argparse.Namespace) -> int:
    from .study.config import load_config, study_estimate

    estimate = study_estimate(load_config(args.config))
    print(f"{args.config}: valid")
    print(f"cases: {estimate.cases} ({estimate.grid_points} grid points before the assembly "
          f"check and family filter)")
    print(f"chunk jobs: {sum(estimate.chunks.values())} ("
          + ", ".join(f"{f} {n}" for f, n in estimate.chunks.items()) + ")")
    print(f"estimated output: {estimate.output_bytes / 1e9:.3g} GB uncompressed")
    print(f"estimated peak memory per chunk job: {estimate.chunk_memory_bytes / 1e9:.3g} GB")
    return 0


def _classify(args: argparse.Namespace) -> int:
    from .problem.mechanism import classify, input_limits

    family = classify(args.ground, args.crank, args.coupler, args.rocker)
    limits = input_limits(args.ground, args.crank, args.coupler, args.rocker)
    result = {"family": family, "input_full_rotation": limits.full_rotation}
    if not limits.full_rotation:
        result.update(input_lower=limits.lower, input_upper=limits.upper,
                      input_lower_deg=math.degrees(limits.lower),
                      input_upper_deg=math.degrees(limits.upper))
    if args.json:
        print(json.dumps(result))
    else:
        print(family)
        if not limits.full_rotation:
            print(f"input angle range: {limits.lower:.6g} .. {limits.upper:.6g} rad "
                  f"({math.degrees(limits.lower):.4g}° .. {math.degrees(limits.upper):.4g}°)")
    return 0


def _ladder(args: argparse.Namespace) -> int:
    from .study.fidelity_ladder import run_scene_ladder

    run_scene_ladder(args.scene, args.output, link=args.link)
    print((Path(args.output) / "ladder.md").read_text())
    return 0


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ced", description="Kineto-elasto-dynamics of flexible planar linkages.")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="simulate one or more scenes and write a netCDF dataset")
    run.add_argument("scenes", nargs="+", help="scene YAML file(s)")
    run.add_argument("-o", "--output", required=True, help="output netCDF file")
    run.set_defaults(func=_run)
    chk = sub.add_parser("check", help="validate a study config and estimate its size")
    chk.add_argument("config", help="study config YAML (as given to snakemake --configfile)")
    chk.set_defaults(func=_check)
    cls = sub.add_parser("classify", help="Grashof family and input limits of a four-bar")
    for name in ("ground", "crank", "coupler", "rocker"):
        cls.add_argument(f"--{name}", type=float, required=True, help=f"{name} length, m")
    cls.add_argument("--json", action="store_true", help="print JSON")
    cls.set_defaults(func=_classify)
    lad = sub.add_parser("ladder", help="run a scene through every model (fidelity ladder)")
    lad.add_argument("scene", help="scene YAML file")
    lad.add_argument("-o", "--output", required=True, help="output directory")
    lad.add_argument("--link", default="coupler", help="link whose results are compared")
    lad.set_defaults(func=_ladder)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``ced`` console script; returns the exit code."""
    from .problem.errors import SceneError

    args = _parser().parse_args(argv)
    try:
        return args.func(args)
    except SceneError as err:
        print(f"ced: error: {err}", file=sys.stderr)
        return 2
    except ValueError as err:
        if args.command == "classify":  # invalid geometry given on the command line
            print(f"ced: error: {err}", file=sys.stderr)
            return 2
        return _failed(err)
    except Exception as err:  # noqa: BLE001 — a failed solve: a message, not a traceback
        return _failed(err)


def _failed(err: Exception) -> int:
    """A run that failed for a reason other than its input: exit 1 with a message (the
    traceback only with ``CED_TRACEBACK=1``)."""
    if os.environ.get("CED_TRACEBACK"):
        raise err
    print(f"ced: error: the run failed: {type(err).__name__}: {err} (set CED_TRACEBACK=1 to "
          "see where)", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
