"""Rule campbell_figure: Campbell diagram of one family.

On its own, for debugging: python workflow/scripts/campbell_figure.py MAP PNG SVG
"""
import sys

if "snakemake" not in globals():  # stand-in for the object Snakemake injects
    from types import SimpleNamespace as NS

    snakemake = NS(input=sys.argv[1:2], output=NS(png=sys.argv[2], svg=sys.argv[3]),
                   log=["/dev/stderr"])

sys.stderr = open(snakemake.log[0], "w")

from ced.plots import campbell_figure  # noqa: E402

campbell_figure(snakemake.input[0], snakemake.output.png, snakemake.output.svg)
