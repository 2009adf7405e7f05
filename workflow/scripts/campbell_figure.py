"""Rule campbell_figure: Campbell diagram of one family.

On its own, for debugging: python workflow/scripts/campbell_figure.py [CONFIG.yaml] family=F
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("campbell_figure", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.figures import campbell_figure  # noqa: E402

campbell_figure(snakemake.input[0], snakemake.output.png, snakemake.output.svg)
