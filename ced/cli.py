"""Command line: ``ced run SCENE.yaml [-o OUT.nc]``, ``ced check CONFIG.yaml``,
``ced classify --ground … --rocker …``, ``ced ladder SCENE.yaml -o DIR``, ``ced compile``,
``ced --version``.

Bad input exits with code 2 and a message naming the key path; nothing is written. A run that
fails for another reason exits 1 with a one-line message. Every subcommand's ``--help`` ends
with examples; :func:`cli_reference` renders them all for the documentation.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

__all__ = ["main", "default_output", "cli_reference", "write_references"]


def default_output(scenes: list[str]) -> str:
    """Where ``ced run`` writes without ``-o``: the first scene's file name with ``.nc``, in
    the current directory.

    Parameters
    ----------
    scenes : list of str
        The scene files given to ``ced run``.

    Returns
    -------
    str
        A file name in the current directory.

    Examples
    --------
    >>> default_output(["config/scenes/sung_thompson.yaml", "other.yaml"])
    'sung_thompson.nc'
    """
    return Path(scenes[0]).with_suffix(".nc").name


def _run(args: argparse.Namespace) -> int:
    from .io import check_output, write_dataset
    from .problem.errors import SceneError
    from .problem.scene import load_scene
    from .problem.status import status_names
    from .study.progress import simulate_in_parts

    if args.output is None:
        args.output = default_output(args.scenes)
    check_output(args.output, inputs=args.scenes)  # before any work
    scenes = []
    for path in args.scenes:  # validate everything before solving
        try:
            scenes.append(load_scene(path))
        except SceneError as err:
            if len(args.scenes) == 1:
                raise
            raise SceneError(err.path, f"{err.message} (in {path})") from None
    ds = simulate_in_parts(scenes, desc="ced run")  # a progress bar on a terminal
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
    cores = args.cores or os.cpu_count() or 1
    print(f"{args.config}: valid")
    print(f"cases: {estimate.cases} ({estimate.grid_points} grid points before the assembly "
          f"check and family filter)")
    for kind, n in estimate.not_assemblable.items():
        print(f"not assemblable over the whole input motion: {n} {kind} geometries (dropped)")
    print(f"chunk jobs: {sum(estimate.chunks.values())} ("
          + ", ".join(f"{f} {n}" for f, n in estimate.chunks.items()) + ")")
    print(f"estimated output: {estimate.output_bytes / 1e9:.3g} GB uncompressed")
    print(f"estimated peak memory per chunk job: {estimate.chunk_memory_bytes / 1e9:.3g} GB")
    print(f"estimated run time on {cores} core{'s' if cores > 1 else ''}: "
          f"{_duration(estimate.run_seconds(cores))} (measured cost model of "
          f"ced.simulation.size and ced.study.config; an unloaded machine)")
    return 0


def _duration(seconds: float) -> str:
    """``45 s``, ``12 min``, ``3.2 h`` for an estimate."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.2g} h"


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


def _compile(args: argparse.Namespace) -> int:
    import time

    from .compile import compile_kernels

    start = time.perf_counter()
    compile_kernels()
    seconds = time.perf_counter() - start
    print(f"kernels compiled, or loaded from numba's cache, in {seconds:.1f} s")
    return 0


_EXAMPLES = {
    "ced": """examples:
  ced run config/scenes/sung_thompson.yaml        # writes sung_thompson.nc here
  ced check config/studies/test.yaml              # validate a study, estimate size and time
  ced classify --ground 0.5 --crank 0.35 --coupler 0.45 --rocker 0.1
  ced ladder config/scenes/reference_four_bar.yaml -o ladder/
  ced compile                                     # once after install (make does it)
  ced SUBCOMMAND --help                           # more on each""",
    "run": """examples:
  ced run config/scenes/sung_thompson.yaml               # writes sung_thompson.nc here
  ced run config/scenes/sung_thompson.yaml -o st.nc
  ced run a.yaml b.yaml c.yaml -o abc.nc                 # three cases in one dataset

Scene keys and defaults: docs/reference/scene.md; the dataset: docs/reference/dataset.md.
A run of many scenes shows a progress bar with the time left (on a terminal only).""",
    "check": """examples:
  ced check config/studies/test.yaml              # 16 cases, about a minute
  ced check config/config.yaml --cores 32         # the default study on 32 cores

Prints the cases, chunk jobs, estimated output size, peak memory per chunk job and run time.
Config keys: docs/reference/config.md.""",
    "classify": """examples:
  ced classify --ground 0.5 --crank 0.1 --coupler 0.45 --rocker 0.35     # crank_rocker
  ced classify --ground 0.5 --crank 0.35 --coupler 0.45 --rocker 0.1 --json""",
    "ladder": """examples:
  ced ladder config/scenes/reference_four_bar.yaml -o ladder/
  ced ladder config/scenes/sung_thompson.yaml -o st_ladder/ --link rocker

Writes ladder.md, ladder.json and ladder.png in the directory (docs/fidelity.md).""",
    "compile": """examples:
  ced compile                 # about 20 s the first time, 1 s once cached

numba compiles each kernel the first time a process calls it and caches the machine code on
disk; without this, the first jobs of a study each compile every kernel (about 15 s each).
The Makefile's install step runs it.""",
}


def _sub(sub, name: str, help: str, description: str) -> argparse.ArgumentParser:
    return sub.add_parser(name, help=help, description=description, epilog=_EXAMPLES[name],
                          formatter_class=argparse.RawDescriptionHelpFormatter)


def _parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = argparse.ArgumentParser(
        prog="ced", description="Kineto-elasto-dynamics of flexible planar linkages.",
        epilog=_EXAMPLES["ced"], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"ced {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="SUBCOMMAND")
    run = _sub(sub, "run", "simulate one or more scenes and write a netCDF dataset",
               "Simulate scenes (YAML files) and write one CF netCDF dataset, one case per "
               "scene. Every scene is validated before any work.")
    run.add_argument("scenes", nargs="+", metavar="SCENE", help="scene YAML file(s)")
    run.add_argument("-o", "--output", default=None,
                     help="output netCDF file (default: the first scene's file name with .nc, "
                          "in the current directory)")
    run.set_defaults(func=_run)
    chk = _sub(sub, "check", "validate a study config and estimate its size and run time",
               "Validate a study config (schema, grids, base scene) and estimate its size, "
               "memory and run time before running it with Snakemake.")
    chk.add_argument("config", metavar="CONFIG",
                     help="study config YAML (as given to snakemake --configfile)")
    chk.add_argument("--cores", type=int, default=None,
                     help="cores to estimate the run time for (default: this machine's)")
    chk.set_defaults(func=_check)
    cls = _sub(sub, "classify", "Grashof family and input limits of a four-bar",
               "Print the Grashof family of a four-bar and, for a rocker input, the range of "
               "its input angle.")
    for name in ("ground", "crank", "coupler", "rocker"):
        cls.add_argument(f"--{name}", type=float, required=True, help=f"{name} length, m")
    cls.add_argument("--json", action="store_true", help="print JSON")
    cls.set_defaults(func=_classify)
    lad = _sub(sub, "ladder", "run a scene through every model (fidelity ladder)",
               "Run one scene through every model (rigid, quasi-static, beams, plane stress, "
               "the thesis's model), each refined until converged, and compare them.")
    lad.add_argument("scene", metavar="SCENE", help="scene YAML file")
    lad.add_argument("-o", "--output", required=True, help="output directory")
    lad.add_argument("--link", default="coupler", help="link whose results are compared")
    lad.set_defaults(func=_ladder)
    cmp = _sub(sub, "compile", "compile the numerical kernels into numba's on-disk cache",
               "Compile every numerical kernel now (two small scenes solved), so that the "
               "first processes of a study load them instead of compiling them.")
    cmp.set_defaults(func=_compile)
    return parser


def cli_reference() -> str:
    """The command-line reference page (Markdown): the ``--help`` of ``ced`` and of every
    subcommand, as printed at a terminal 92 columns wide.

    Returns
    -------
    str
        The text of ``docs/reference/cli.md``, ending with a newline.
    """
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "92"  # argparse wraps to the terminal's width: fix it
    try:
        parser = _parser()
        parts = ["# Command-line reference", "",
                 "<!-- Generated from ced/cli.py by `make reference`; do not edit by hand. -->",
                 "", "```text", "$ ced --help", parser.format_help().rstrip(), "```", ""]
        subparsers = next(a for a in parser._actions
                          if isinstance(a, argparse._SubParsersAction))
        for name, sub in subparsers.choices.items():
            parts += [f"## `ced {name}`", "", "```text", f"$ ced {name} --help",
                      sub.format_help().rstrip(), "```", ""]
    finally:
        if previous is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = previous
    return "\n".join(parts)


def write_references(directory: str | Path) -> list[Path]:
    """Write every generated reference page into ``directory`` (``make reference``): the scene,
    study-config and dataset references (:func:`ced.study.reference.write_references`) and the
    command-line reference (:func:`cli_reference`). Returns the paths written.

    Parameters
    ----------
    directory : str or Path
        Target folder (``docs/reference``).

    Returns
    -------
    list of Path
        The files written.
    """
    from .study.reference import write_references as write_lower

    paths = write_lower(directory)
    path = Path(directory) / "cli.md"
    path.write_text(cli_reference(), encoding="utf-8")
    return [*paths, path]


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``ced`` console script; returns the exit code.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 for bad input (a message names the key), 1 for a run that failed for
        another reason.
    """
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
