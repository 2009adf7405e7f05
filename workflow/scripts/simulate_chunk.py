"""Rule simulate_chunk: run the KED solver on one (family, chunk) of the study's cases.

On its own, for debugging: python workflow/scripts/simulate_chunk.py [CONFIG.yaml] family=F chunk=N
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("simulate_chunk", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.chunk_job import run_chunk  # noqa: E402

run_chunk(snakemake.params.cases, snakemake.wildcards.family, int(snakemake.wildcards.chunk),
          snakemake.output[0], study=snakemake.wildcards.study)
