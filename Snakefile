# ced study pipeline: simulate chunks of cases -> reduce per family -> maps, figures -> report.
# Nothing heavy at parse time: the case table is a pure function of the config (ced.study.cases).
#
#   snakemake --profile workflow/profiles/default                       # default study
#   snakemake --profile workflow/profiles/default --configfile config/studies/<name>.yaml
#   snakemake --profile workflow/profiles/default --configfile config/studies/<name>.yaml \
#       --report results/<name>/report.html     # the report of that study (docs/guide/first_study.md)
#
# The profiles set replace-workflow-config: a --configfile study replaces config/config.yaml
# instead of being merged into it (Snakemake merges nested keys by default).
from ced.study.cases import case_config, estimate_requested, modal_requested
from ced.study.config import check_config


configfile: "config/config.yaml"


# The schema (workflow/schemas/config.schema.yaml, defaults filled in) and every check the
# schema cannot express, with the estimated study size: bad input fails here, before any job.
CHUNKS = check_config(config)
STUDY = config["study"]
FAMILIES = sorted(CHUNKS)
CAMPBELL = modal_requested(config)
ESTIMATED = estimate_requested(config)
# Convergence study (config key `convergence`, ced.study.convergence): one job per family of its sweep;
# none, and no report section, without the key.
CONVERGENCE = None
if config.get("convergence"):
    from ced.study.convergence import load_sweep

    CONVERGENCE = load_sweep(config, root=workflow.basedir)
CONVERGENCE_FAMILIES = list(CONVERGENCE["families"]) if CONVERGENCE else []


report: "workflow/report/workflow.rst"


wildcard_constraints:
    study=STUDY,
    family="|".join(FAMILIES) if FAMILIES else "none",
    chunk=r"\d+",


include: "workflow/rules/simulate.smk"
include: "workflow/rules/reduce.smk"
include: "workflow/rules/figures.smk"
include: "workflow/rules/ladder.smk"
include: "workflow/rules/convergence.smk"


localrules:
    all,


rule all:
    default_target: True
    input:
        expand("results/{study}/maps/{family}.nc", study=STUDY, family=FAMILIES),
        expand("results/{study}/maps/{family}_grid.nc", study=STUDY, family=FAMILIES),
        expand(
            "results/{study}/figures/overview.{ext}", study=STUDY, ext=("png", "svg")
        ),
        expand(
            "results/{study}/figures/error_estimate.{ext}",
            study=STUDY if ESTIMATED else [],
            ext=("png", "svg"),
        ),
        expand("results/{study}/ladder/ladder.md", study=STUDY),
        expand(
            "results/{study}/tables/accuracy.{ext}",
            study=STUDY if CONVERGENCE_FAMILIES else [],
            ext=("md", "csv"),
        ),
        expand(
            "results/{study}/figures/accuracy/{family}.{ext}",
            study=STUDY,
            family=CONVERGENCE_FAMILIES,
            ext=("png", "svg"),
        ),
        expand(
            "results/{study}/figures/{kind}/{family}.{ext}",
            study=STUDY,
            kind=("resonance", "worst_case"),
            family=FAMILIES,
            ext=("png", "svg"),
        ),
        expand("results/{study}/tables/safe_speed.{ext}", study=STUDY, ext=("csv", "md")),
        expand(
            "results/{study}/figures/campbell/{family}.{ext}",
            study=STUDY,
            family=FAMILIES if CAMPBELL else [],
            ext=("png", "svg"),
        ),
