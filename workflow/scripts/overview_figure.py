import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from ced.plots import overview_figure  # noqa: E402

overview_figure(list(snakemake.input), snakemake.output[0])  # noqa: F821
