"""Rule simulate_chunk: run the KED solver on one (family, chunk) of the study's cases.

On its own, for debugging: python workflow/scripts/simulate_chunk.py CONFIG FAMILY CHUNK OUT
"""
import sys

if "snakemake" not in globals():  # stand-in for the object Snakemake injects
    from pathlib import Path
    from types import SimpleNamespace as NS

    import yaml
    from snakemake.utils import validate

    from ced.study import case_config

    config = yaml.safe_load(open(sys.argv[1]))
    validate(config, str(Path(__file__).resolve().parents[1] / "schemas/config.schema.yaml"))
    snakemake = NS(params=NS(cases=case_config(config)), output=[sys.argv[4]], log=["/dev/stderr"],
                   wildcards=NS(study=config["study"], family=sys.argv[2], chunk=sys.argv[3]))

sys.stderr = open(snakemake.log[0], "w")

from ced.study import run_chunk  # noqa: E402

run_chunk(snakemake.params.cases, snakemake.wildcards.family, int(snakemake.wildcards.chunk),
          snakemake.output[0], study=snakemake.wildcards.study)
