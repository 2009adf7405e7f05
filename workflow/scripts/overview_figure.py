"""Rule overview_figure: peak input torque and peak stress against speed, every family.

On its own, for debugging: python workflow/scripts/overview_figure.py [CONFIG.yaml]
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("overview_figure", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.figures import overview_figure  # noqa: E402

overview_figure(list(snakemake.input), snakemake.output.png, snakemake.output.svg)
