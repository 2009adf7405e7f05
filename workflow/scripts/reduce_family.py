"""Rule reduce_family: chunk files -> per-case peaks (maps/<family>.nc) and grid map.

On its own, for debugging: python workflow/scripts/reduce_family.py [CONFIG.yaml] family=F
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("reduce_family", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.maps import reduce_family  # noqa: E402

reduce_family(list(snakemake.input), snakemake.output.cases, snakemake.output.grid,
              snakemake.params.stress_safety_factor)
