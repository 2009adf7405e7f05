"""Rule fidelity_ladder: every model on the reference scene, table and figure.

On its own, for debugging: python workflow/scripts/fidelity_ladder.py SCENE OUTDIR
"""
import sys
from pathlib import Path

if "snakemake" not in globals():  # stand-in for the object Snakemake injects
    from types import SimpleNamespace as NS

    snakemake = NS(input=NS(scene=sys.argv[1]),
                   output=NS(table=str(Path(sys.argv[2]) / "ladder.md")), log=["/dev/stderr"])

sys.stderr = open(snakemake.log[0], "w")

from ced.ladder import run_scene_ladder  # noqa: E402

run_scene_ladder(snakemake.input.scene, Path(snakemake.output.table).parent)
