rule simulate_chunk:
    """Run the KED solver on one chunk of a family's cases (one job, many cases)."""
    output:
        "results/{study}/chunks/{family}/{chunk}.nc",
    log:
        "results/{study}/logs/simulate/{family}/{chunk}.log",
    benchmark:
        "results/{study}/benchmarks/simulate/{family}/{chunk}.tsv"
    params:
        config=config,
    threads: 1
    resources:
        mem_mb=lambda wildcards, attempt: 2000 * attempt,
        runtime=lambda wildcards, attempt: 30 * attempt,
    script:
        "../scripts/simulate_chunk.py"
