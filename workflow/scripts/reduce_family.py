"""Rule reduce_family: chunk files -> per-case peaks (maps/<family>.nc) and grid map.

On its own, for debugging: python workflow/scripts/reduce_family.py CASES_OUT GRID_OUT CHUNK...
"""
import sys

if "snakemake" not in globals():  # stand-in for the object Snakemake injects
    from types import SimpleNamespace as NS

    snakemake = NS(input=sys.argv[3:], output=NS(cases=sys.argv[1], grid=sys.argv[2]),
                   params=NS(stress_safety_factor=2.0), log=["/dev/stderr"])

sys.stderr = open(snakemake.log[0], "w")

from ced.reduce import reduce_family  # noqa: E402

reduce_family(list(snakemake.input), snakemake.output.cases, snakemake.output.grid,
              snakemake.params.stress_safety_factor)
