"""Rule resonance_map: speed x length map of one family's peak stress with harmonic curves.

On its own, for debugging: python workflow/scripts/resonance_map.py GRID PNG SVG [MATERIAL]
"""
import sys

if "snakemake" not in globals():  # stand-in for the object Snakemake injects
    from types import SimpleNamespace as NS

    snakemake = NS(input=sys.argv[1:2], output=NS(png=sys.argv[2], svg=sys.argv[3]),
                   params=NS(material=(sys.argv[4:5] or [None])[0]), log=["/dev/stderr"])

sys.stderr = open(snakemake.log[0], "w")

from ced.plots import resonance_map  # noqa: E402

resonance_map(snakemake.input[0], snakemake.output.png, snakemake.output.svg,
              material=snakemake.params.material)
