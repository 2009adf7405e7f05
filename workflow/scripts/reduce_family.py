import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from ced.reduce import reduce_family  # noqa: E402

reduce_family(list(snakemake.input), snakemake.output[0])  # noqa: F821
