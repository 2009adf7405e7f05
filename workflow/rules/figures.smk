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
