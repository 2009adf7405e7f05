# Convergence study (ced.study.convergence): what accuracy costs in time. Families come from the
# sweep of the config key `convergence` (Snakefile: CONVERGENCE, CONVERGENCE_FAMILIES); without
# it these rules make no jobs.
import re as _re


rule convergence_family:
    """One family's reference scene over the sweep: errors vs a Richardson reference, time."""
    output:
        "results/{study}/convergence/{family}.nc",
    log:
        "results/{study}/logs/convergence/{family}.log",
    benchmark:
        "results/{study}/benchmarks/convergence/{family}.tsv"
    wildcard_constraints:
        family="|".join(map(_re.escape, CONVERGENCE_FAMILIES)) or "none",
    threads: 1
    resources:
        mem_mb=lambda wildcards, attempt: 2000 * attempt,
        runtime=lambda wildcards, attempt: 60 * attempt,
    params:
        # The validated sweep with only this family kept. Params are a rerun trigger: editing
        # the sweep or this family's scene re-runs the job; editing another family or the study
        # part of the file holding the sweep does not (hence no input file).
        sweep=lambda wildcards: {
            **CONVERGENCE,
            "families": {wildcards.family: CONVERGENCE["families"][wildcards.family]},
        },
    script:
        "../scripts/convergence_family.py"


rule pareto_figure:
    """One family's Pareto plot (error against solve time), as soon as its sweep is done."""
    input:
        "results/{study}/convergence/{family}.nc",
    output:
        png=report(
            "results/{study}/figures/accuracy/{family}.png",
            caption="../report/accuracy_pareto.rst",
            category="What accuracy costs in time",
            labels={"figure": "Pareto {family}", "format": "PNG"},
        ),
        svg="results/{study}/figures/accuracy/{family}.svg",
    log:
        "results/{study}/logs/figures/accuracy/{family}.log",
    wildcard_constraints:
        family="|".join(map(_re.escape, CONVERGENCE_FAMILIES)) or "none",
    resources:
        mem_mb=lambda wildcards, attempt: 1000 * attempt,
        runtime=lambda wildcards, attempt: 10 * attempt,
    script:
        "../scripts/pareto_figure.py"


rule convergence_summary:
    """All families: accuracy table (cheapest setting per target) and the error-estimate check."""
    input:
        expand("results/{{study}}/convergence/{family}.nc", family=CONVERGENCE_FAMILIES),
    output:
        csv=report(
            "results/{study}/tables/accuracy.csv",
            caption="../report/accuracy_table.rst",
            category="What accuracy costs in time",
            labels={"figure": "accuracy table", "format": "CSV"},
        ),
        md=report(
            "results/{study}/tables/accuracy.md",
            caption="../report/accuracy_table.rst",
            category="What accuracy costs in time",
            labels={"figure": "accuracy table", "format": "markdown"},
        ),
        estimate_png=report(
            "results/{study}/figures/accuracy/estimate.png",
            caption="../report/accuracy_estimate.rst",
            category="What accuracy costs in time",
            labels={"figure": "error estimate", "format": "PNG"},
        ),
        estimate_svg="results/{study}/figures/accuracy/estimate.svg",
    log:
        "results/{study}/logs/tables/accuracy.log",
    resources:
        mem_mb=lambda wildcards, attempt: 1000 * attempt,
        runtime=lambda wildcards, attempt: 10 * attempt,
    script:
        "../scripts/convergence_summary.py"
