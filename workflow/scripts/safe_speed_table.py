"""Rule safe_speed_table: safe speed limit per geometry of every family, CSV and markdown.

On its own, for debugging: python workflow/scripts/safe_speed_table.py [CONFIG.yaml]
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("safe_speed_table", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.safe_speed import write_safe_speed_table  # noqa: E402

write_safe_speed_table(list(snakemake.input), snakemake.output.csv, snakemake.output.md,
                       snakemake.params.stress_safety_factor,
                       snakemake.params.fatigue_safety_factor, snakemake.params.error_tolerance)
