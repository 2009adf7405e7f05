rule reduce_family:
    """A family's chunk files -> per-case peaks and the same unstacked onto the study grid."""
    input:
        lambda wildcards: expand(
            "results/{study}/chunks/{family}/{chunk}.nc",
            study=wildcards.study,
            family=wildcards.family,
            chunk=range(CHUNKS[wildcards.family]),
        ),
    output:
        cases="results/{study}/maps/{family}.nc",
        grid="results/{study}/maps/{family}_grid.nc",
    log:
        "results/{study}/logs/reduce/{family}.log",
    benchmark:
        "results/{study}/benchmarks/reduce/{family}.tsv"
    resources:
        mem_mb=lambda wildcards, attempt: 1000 * attempt,
        runtime=lambda wildcards, attempt: 10 * attempt,
    params:
        stress_safety_factor=config["stress_safety_factor"],
    script:
        "../scripts/reduce_family.py"
