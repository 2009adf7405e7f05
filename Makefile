# Two entry points for a fresh machine with Python 3.11 and pip:
#   make study   -> set up .venv, run the default study end to end
#   make test    -> set up .venv, run the test suite
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
CORES ?= 2

.PHONY: study test bench clean cluster-test

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[test]"
	touch $(STAMP)

study: $(STAMP)
	$(BIN)/snakemake --profile workflow/profiles/default --cores $(CORES)
	$(BIN)/snakemake --profile workflow/profiles/default --cores $(CORES) --report results/default/report.html

test: $(STAMP)
	$(BIN)/python -m pytest -q -n $(CORES) tests ced

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

# Long, needs root: a single-node SLURM on this machine (apt-get slurm-wlm munge), the executor
# plugin pip-installed into .venv, the test study through workflow/profiles/slurm vs. locally.
cluster-test: $(STAMP)
	BIN=$(BIN) tests/cluster/run.sh

clean:
	rm -rf $(VENV) results .snakemake
