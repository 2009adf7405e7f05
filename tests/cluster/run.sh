#!/usr/bin/env bash
# make cluster-test: start a single-node SLURM (start_slurm.sh), install the executor plugin into
# the venv, run tests/test_cluster.py (test study through workflow/profiles/slurm vs. locally),
# and stop the daemons whatever happens.
set -euo pipefail
cd "$(dirname "$0")/../.."
BIN="${BIN:-.venv/bin}"
trap 'tests/cluster/stop_slurm.sh' EXIT
tests/cluster/start_slurm.sh
"$BIN/pip" install --quiet -e ".[cluster]"  # snakemake-executor-plugin-slurm
"$BIN/snakemake" --help | grep -q -- "--slurm-status-command" \
    || { echo "run.sh: the installed slurm plugin has no --slurm-status-command" >&2; exit 1; }
CED_CLUSTER=1 "$BIN/python" -m pytest -q -p no:cacheprovider tests/test_cluster.py
