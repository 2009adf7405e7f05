"""One stand-in for the ``snakemake`` object, so that any workflow script runs on its own.

Snakemake injects a ``snakemake`` object (input, output, params, wildcards, log, config) into
the scripts it runs. For debugging, every script builds the same object from the real
Snakefile instead (as PyPSA-Eur's ``mock_snakemake``): the rule's own input, output, params
and log for the wildcards given, with the config of the Snakefile or of a study config::

    python workflow/scripts/simulate_chunk.py family=crank_rocker chunk=0
    python workflow/scripts/reduce_family.py config/studies/test.yaml family=change_point

Arguments: ``name=value`` sets a wildcard (``study`` defaults to the config's study); a path
ending in ``.yaml`` is a study config that replaces ``config/config.yaml``, as the profiles do.
Paths are made absolute and the working directory becomes the repository root.
"""
from __future__ import annotations

import logging
import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def mock_snakemake(rule: str, *args: str):
    """The ``snakemake`` object of ``rule`` for the wildcards and config in ``args``.

    Parameters
    ----------
    rule : str
        Rule name in the Snakefile, e.g. ``"simulate_chunk"``.
    *args : str
        ``name=value`` wildcards and at most one study config path (``*.yaml``).

    Returns
    -------
    snakemake.script.Snakemake
        What the script would see when run by Snakemake.
    """
    import snakemake as sm
    from snakemake.api import Workflow
    from snakemake.logging import LoggerManager
    from snakemake.script import Snakemake
    from snakemake.settings.types import (ConfigSettings, DAGSettings, OutputSettings,
                                          ResourceSettings, StorageSettings, WorkflowSettings)

    configs = [Path(a).resolve() for a in args if a.endswith((".yaml", ".yml"))]
    wildcards = dict(a.split("=", 1) for a in args if "=" in a)
    unknown = [a for a in args if a not in wildcards and "=" not in a
               and not a.endswith((".yaml", ".yml"))]
    if len(configs) > 1 or unknown:
        raise SystemExit(f"usage: {rule}: [CONFIG.yaml] name=value ...; got {' '.join(args)}")
    os.chdir(ROOT)
    workflow = Workflow(
        ConfigSettings(configfiles=configs, replace_workflow_config=bool(configs)),
        ResourceSettings(), WorkflowSettings(),
        LoggerManager(logging.getLogger("snakemake"), OutputSettings(quiet={"all"})),
        StorageSettings(), DAGSettings(rerun_triggers=[]), storage_provider_settings={})
    workflow.include(ROOT / "Snakefile")
    workflow.global_resources = {}
    job_rule = workflow.get_rule(rule)
    wildcards.setdefault("study", workflow.config["study"])
    wildcards = {k: v for k, v in wildcards.items() if k in job_rule.wildcard_names}
    job = sm.jobs.Job(job_rule, sm.dag.DAG(workflow, rules=[job_rule]), wildcards)
    for files in (job.input, job.output, job.log):
        for i, path in enumerate(files):
            files[i] = os.path.abspath(path)
    for path in [*job.log, *job.output]:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
    return Snakemake(job.input, job.output, job.params, job.wildcards, job.threads,
                     job.resources, job.log, workflow.config, job_rule.name, None)
