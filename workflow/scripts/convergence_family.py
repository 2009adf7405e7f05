"""Rule convergence_family: one family's reference scene over the convergence sweep.

On its own, for debugging: python workflow/scripts/convergence_family.py CONFIG FAMILY OUT
"""
import sys

if "snakemake" not in globals():  # stand-in for the object Snakemake injects
    from pathlib import Path
    from types import SimpleNamespace as NS

    import yaml

    from ced.convergence import load_sweep

    root = Path(__file__).resolve().parents[2]  # a `convergence` path is relative to the repo
    snakemake = NS(params=NS(sweep=load_sweep(yaml.safe_load(open(sys.argv[1])), root=root)),
                   wildcards=NS(family=sys.argv[2]), output=[sys.argv[3]], log=["/dev/stderr"])

sys.stderr = open(snakemake.log[0], "w")

from ced.convergence import run_family  # noqa: E402
from ced.io import write_dataset  # noqa: E402

write_dataset(run_family(snakemake.params.sweep, snakemake.wildcards.family),
              snakemake.output[0])
