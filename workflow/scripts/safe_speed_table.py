"""Rule safe_speed_table: safe speed limit per geometry of every family, CSV and markdown.

On its own, for debugging: python workflow/scripts/safe_speed_table.py CSV MD FACTOR MAP...
"""
import sys

if "snakemake" not in globals():  # stand-in for the object Snakemake injects
    from types import SimpleNamespace as NS

    snakemake = NS(input=sys.argv[4:], output=NS(csv=sys.argv[1], md=sys.argv[2]),
                   params=NS(stress_safety_factor=float(sys.argv[3])), log=["/dev/stderr"])

sys.stderr = open(snakemake.log[0], "w")

from ced.reduce import write_safe_speed_table  # noqa: E402

write_safe_speed_table(list(snakemake.input), snakemake.output.csv, snakemake.output.md,
                       snakemake.params.stress_safety_factor)
