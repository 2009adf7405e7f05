"""Rule worst_case_figure: stress history and deformed linkage of a family's worst credible and flagged cases.

On its own, for debugging: python workflow/scripts/worst_case_figure.py [CONFIG.yaml] family=F
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("worst_case_figure", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.figures import worst_case_figure  # noqa: E402

worst_case_figure(snakemake.input.summary, list(snakemake.input.chunks), snakemake.output.png,
                  snakemake.output.svg, snakemake.params.error_tolerance)
