"""Rule convergence_summary: accuracy table (CSV, markdown), Pareto plot per family and the
error-estimate check, from the families' convergence files.

On its own, for debugging: python workflow/scripts/convergence_summary.py OUTDIR FAMILY_NC...
(writes OUTDIR/accuracy.{csv,md}, OUTDIR/<family>.{png,svg}, OUTDIR/estimate.{png,svg})
"""
import sys

if "snakemake" not in globals():  # stand-in for the object Snakemake injects
    from pathlib import Path
    from types import SimpleNamespace as NS

    out, paths = Path(sys.argv[1]), sys.argv[2:]
    families = [Path(p).stem for p in paths]
    snakemake = NS(input=paths, params=NS(families=families), log=["/dev/stderr"],
                   output=NS(csv=str(out / "accuracy.csv"), md=str(out / "accuracy.md"),
                             png=[str(out / f"{f}.png") for f in families],
                             svg=[str(out / f"{f}.svg") for f in families],
                             estimate_png=str(out / "estimate.png"),
                             estimate_svg=str(out / "estimate.svg")))

sys.stderr = open(snakemake.log[0], "w")

from ced.accuracy_plots import write_accuracy_summary  # noqa: E402

families = list(snakemake.params.families)
png, svg = snakemake.output.png, snakemake.output.svg
png, svg = ([png], [svg]) if isinstance(png, str) else (list(png), list(svg))
write_accuracy_summary(
    list(snakemake.input), snakemake.output.csv, snakemake.output.md,
    dict(zip(families, zip(png, svg))),
    (snakemake.output.estimate_png, snakemake.output.estimate_svg))
