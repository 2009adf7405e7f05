# ced study pipeline: simulate chunks of cases -> reduce per family -> figures -> report.
# Nothing heavy at parse time: the case table is a pure function of the config (ced.study).
from snakemake.utils import validate

from ced.study import chunks


configfile: "config/config.yaml"


validate(config, "workflow/schemas/config.schema.yaml")

STUDY = config["study"]
CHUNKS = chunks(config)
FAMILIES = sorted(CHUNKS)


wildcard_constraints:
    family="|".join(FAMILIES) if FAMILIES else "none",
    chunk=r"\d+",


include: "workflow/rules/simulate.smk"
include: "workflow/rules/reduce.smk"


rule all:
    default_target: True
    input:
        expand("results/{study}/maps/{family}.nc", study=STUDY, family=FAMILIES),
        expand("results/{study}/figures/overview.png", study=STUDY),
