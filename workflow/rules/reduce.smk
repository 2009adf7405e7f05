rule reduce_family:
    """Combine a family's chunk files into one CF dataset of per-case results."""
    input:
        lambda wildcards: expand(
            "results/{study}/chunks/{family}/{chunk}.nc",
            study=wildcards.study,
            family=wildcards.family,
            chunk=range(CHUNKS[wildcards.family]),
        ),
    output:
        "results/{study}/maps/{family}.nc",
    log:
        "results/{study}/logs/reduce/{family}.log",
    script:
        "../scripts/reduce_family.py"


rule overview_figure:
    """Family overview: peak input torque (and peak stress where computed) against speed."""
    input:
        expand("results/{{study}}/maps/{family}.nc", family=FAMILIES),
    output:
        report(
            "results/{study}/figures/overview.png",
            caption="../report/overview.rst",
            category="Overview",
        ),
    log:
        "results/{study}/logs/figures/overview.log",
    script:
        "../scripts/overview_figure.py"
