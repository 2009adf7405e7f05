"""Rule overview_figure: peak input torque and peak stress against speed, every family.

On its own, for debugging: python workflow/scripts/overview_figure.py PNG SVG MAP...
"""
import sys

if "snakemake" not in globals():  # stand-in for the object Snakemake injects
    from types import SimpleNamespace as NS

    snakemake = NS(input=sys.argv[3:], output=NS(png=sys.argv[1], svg=sys.argv[2]),
                   log=["/dev/stderr"])

sys.stderr = open(snakemake.log[0], "w")

from ced.plots import overview_figure  # noqa: E402

overview_figure(list(snakemake.input), snakemake.output.png, snakemake.output.svg)
