"""Rule convergence_summary: accuracy table (CSV, markdown) and the error-estimate check, from
the families' convergence files.

On its own, for debugging: python workflow/scripts/convergence_summary.py [CONFIG.yaml]
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("convergence_summary", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.convergence_figures import write_accuracy_summary  # noqa: E402

write_accuracy_summary(list(snakemake.input), snakemake.output.csv, snakemake.output.md,
                       (snakemake.output.estimate_png, snakemake.output.estimate_svg))
