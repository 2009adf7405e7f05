"""Rule estimate_figure: the distribution of the study's error estimates, every family.

On its own, for debugging: python workflow/scripts/estimate_figure.py [CONFIG.yaml]
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("estimate_figure", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.figures import estimate_figure  # noqa: E402

estimate_figure(list(snakemake.input), snakemake.output.png, snakemake.output.svg)
