rule overview_figure:
    """Family overview: peak input torque (and peak stress where computed) against speed."""
    input:
        expand("results/{{study}}/maps/{family}.nc", family=FAMILIES),
    output:
        png=report(
            "results/{study}/figures/overview.png",
            caption="../report/overview.rst",
            category="Overview",
            labels={"figure": "overview", "format": "PNG"},
        ),
        svg=report(
            "results/{study}/figures/overview.svg",
            caption="../report/overview.rst",
            category="Overview",
            labels={"figure": "overview", "format": "SVG"},
        ),
    log:
        "results/{study}/logs/figures/overview.log",
    script:
        "../scripts/overview_figure.py"


rule campbell_figure:
    """Campbell diagram of one family: frequency bands against speed, crank harmonics."""
    input:
        "results/{study}/maps/{family}.nc",
    output:
        png=report(
            "results/{study}/figures/campbell/{family}.png",
            caption="../report/campbell.rst",
            category="Campbell diagrams",
            labels={"family": "{family}", "format": "PNG"},
        ),
        svg=report(
            "results/{study}/figures/campbell/{family}.svg",
            caption="../report/campbell.rst",
            category="Campbell diagrams",
            labels={"family": "{family}", "format": "SVG"},
        ),
    log:
        "results/{study}/logs/figures/campbell/{family}.log",
    script:
        "../scripts/campbell_figure.py"


rule resonance_map:
    """Resonance map of one family: a panel per material and section, harmonics k*Omega/2pi = f1."""
    input:
        "results/{study}/maps/{family}_grid.nc",
    output:
        png=report(
            "results/{study}/figures/resonance/{family}.png",
            caption="../report/resonance.rst",
            category="Resonance maps",
            labels={"family": "{family}", "format": "PNG"},
        ),
        svg=report(
            "results/{study}/figures/resonance/{family}.svg",
            caption="../report/resonance.rst",
            category="Resonance maps",
            labels={"family": "{family}", "format": "SVG"},
        ),
    log:
        "results/{study}/logs/figures/resonance/{family}.log",
    params:
        y=config["resonance_map"].get("y"),
        fixed=config["resonance_map"].get("fixed"),
        error_tolerance=config["error_tolerance"],
    script:
        "../scripts/resonance_map.py"


rule worst_case_figure:
    """Stress history and deformed linkage of the family's worst credible and flagged cases."""
    input:
        summary="results/{study}/maps/{family}.nc",
        chunks=lambda wildcards: expand(
            "results/{study}/chunks/{family}/{chunk}.nc",
            study=wildcards.study,
            family=wildcards.family,
            chunk=range(CHUNKS[wildcards.family]),
        ),
    output:
        png=report(
            "results/{study}/figures/worst_case/{family}.png",
            caption="../report/worst_case.rst",
            category="Worst cases",
            labels={"family": "{family}", "format": "PNG"},
        ),
        svg=report(
            "results/{study}/figures/worst_case/{family}.svg",
            caption="../report/worst_case.rst",
            category="Worst cases",
            labels={"family": "{family}", "format": "SVG"},
        ),
    log:
        "results/{study}/logs/figures/worst_case/{family}.log",
    params:
        error_tolerance=config["error_tolerance"],
    script:
        "../scripts/worst_case_figure.py"


rule safe_speed_table:
    """Safe speed limit per geometry: credible cases within yield and fatigue limits."""
    input:
        expand("results/{{study}}/maps/{family}.nc", family=FAMILIES),
    output:
        csv=report(
            "results/{study}/tables/safe_speed.csv",
            caption="../report/safe_speed.rst",
            category="Safe speed limits",
        ),
        md="results/{study}/tables/safe_speed.md",
    log:
        "results/{study}/logs/tables/safe_speed.log",
    params:
        stress_safety_factor=config["stress_safety_factor"],
        fatigue_safety_factor=config["fatigue_safety_factor"],
        error_tolerance=config["error_tolerance"],
    script:
        "../scripts/safe_speed_table.py"


rule estimate_figure:
    """How accurate the study is by its own error estimate: its distribution over the cases."""
    input:
        expand("results/{{study}}/maps/{family}.nc", family=FAMILIES),
    output:
        png=report(
            "results/{study}/figures/error_estimate.png",
            caption="../report/error_estimate.rst",
            category="Overview",
            labels={"figure": "error estimate", "format": "PNG"},
        ),
        svg=report(
            "results/{study}/figures/error_estimate.svg",
            caption="../report/error_estimate.rst",
            category="Overview",
            labels={"figure": "error estimate", "format": "SVG"},
        ),
    log:
        "results/{study}/logs/figures/error_estimate.log",
    script:
        "../scripts/estimate_figure.py"
