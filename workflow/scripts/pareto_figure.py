"""Rule pareto_figure: one family's Pareto plot (error against solve time) from its convergence
file.

On its own, for debugging: python workflow/scripts/pareto_figure.py [CONFIG.yaml] family=F
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("pareto_figure", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.convergence_figures import write_pareto_figure  # noqa: E402

write_pareto_figure(snakemake.input[0], snakemake.output.png, snakemake.output.svg)
