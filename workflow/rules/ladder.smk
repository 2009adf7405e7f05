rule fidelity_ladder:
    """Every model on the reference scene, refined until converged (ced.study.fidelity_ladder)."""
    input:
        scene=f"{workflow.basedir}/config/scenes/reference_four_bar.yaml",
    output:
        table="results/{study}/ladder/ladder.md",
        data="results/{study}/ladder/ladder.json",
        png=report(
            "results/{study}/ladder/ladder.png",
            caption="../report/ladder.rst",
            category="What accuracy costs in time",
            labels={"figure": "fidelity ladder", "format": "PNG"},
        ),
        svg="results/{study}/ladder/ladder.svg",
    log:
        "results/{study}/logs/ladder.log",
    benchmark:
        "results/{study}/benchmarks/ladder.tsv"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=20,
    script:
        "../scripts/fidelity_ladder.py"
