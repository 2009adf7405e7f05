rule simulate_chunk:
    """Run the KED solver on one chunk of a family's cases (one job, many cases)."""
    output:
        "results/{study}/chunks/{family}/{chunk}.nc",
    log:
        "results/{study}/logs/simulate/{family}/{chunk}.log",
    benchmark:
        "results/{study}/benchmarks/simulate/{family}/{chunk}.tsv"
    threads: 1
    resources:
        mem_mb=lambda wildcards, attempt: 2000 * attempt,
        runtime=lambda wildcards, attempt: 30 * attempt,
    params:
        # Only the config keys that define the cases: editing the study name, the families
        # kept or a reduction setting re-runs no simulation.
        cases=case_config(config),
    script:
        "../scripts/simulate_chunk.py"
