"""Rule fidelity_ladder: every model on the reference scene, table and figure.

On its own, for debugging: python workflow/scripts/fidelity_ladder.py [CONFIG.yaml]
"""
import sys
from pathlib import Path

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("fidelity_ladder", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.fidelity_ladder import run_scene_ladder  # noqa: E402

run_scene_ladder(snakemake.input.scene, Path(snakemake.output.table).parent)
