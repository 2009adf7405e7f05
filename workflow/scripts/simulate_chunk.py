import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821 (snakemake object injected)

from ced.study import run_chunk  # noqa: E402

run_chunk(
    snakemake.params.config,  # noqa: F821
    snakemake.wildcards.family,  # noqa: F821
    int(snakemake.wildcards.chunk),  # noqa: F821
    snakemake.output[0],  # noqa: F821
)
