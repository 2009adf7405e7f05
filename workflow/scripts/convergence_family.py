"""Rule convergence_family: one family's reference scene over the convergence sweep.

On its own, for debugging: python workflow/scripts/convergence_family.py [CONFIG.yaml] family=F
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("convergence_family", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.convergence import run_family  # noqa: E402
from ced.io import write_dataset  # noqa: E402

write_dataset(run_family(snakemake.params.sweep, snakemake.wildcards.family),
              snakemake.output[0])
