"""Rule worst_case_figure: time history and deformed linkage of a family's worst case.

On its own, for debugging: python workflow/scripts/worst_case_figure.py MAP PNG SVG CHUNK...
"""
import sys

if "snakemake" not in globals():  # stand-in for the object Snakemake injects
    from types import SimpleNamespace as NS

    snakemake = NS(input=NS(summary=sys.argv[1], chunks=sys.argv[4:]),
                   output=NS(png=sys.argv[2], svg=sys.argv[3]), log=["/dev/stderr"])

sys.stderr = open(snakemake.log[0], "w")

from ced.plots import worst_case_figure  # noqa: E402

worst_case_figure(snakemake.input.summary, list(snakemake.input.chunks), snakemake.output.png,
                  snakemake.output.svg)
