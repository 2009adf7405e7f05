"""Rule resonance_map: speed x length map of one family's peak stress with harmonic curves.

On its own, for debugging: python workflow/scripts/resonance_map.py [CONFIG.yaml] family=F
"""
import sys

if "snakemake" not in globals():  # run on its own: the Snakefile's rule, as Snakemake would
    from _stand_in import mock_snakemake

    snakemake = mock_snakemake("resonance_map", *sys.argv[1:])

sys.stderr = open(snakemake.log[0], "w")

from ced.study.resonance_maps import resonance_map  # noqa: E402

resonance_map(snakemake.input[0], snakemake.output.png, snakemake.output.svg,
              y=snakemake.params.y, fixed=snakemake.params.fixed,
              error_tolerance=snakemake.params.error_tolerance)
