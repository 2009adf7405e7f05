# Two entry points for a fresh machine with Python 3.11 and pip:
#   make study   -> set up .venv, run the default study end to end
#   make test    -> set up .venv, run the test suite
#   make docs    -> the documentation site in docs/_build/html (warnings are errors)
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
CORES ?= 2

.PHONY: study test docs reference bench bench-memory clean cluster-test

# ced compile: numba's kernels compiled once here (about 20 s), as a C extension would be at
# install, instead of in the first jobs of every study and test run (ced/compile.py).
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[test]"
	$(BIN)/ced compile
	touch $(STAMP)

# The docs extra (Sphinx, numpydoc, sphinx-gallery, MyST) on top of the test install.
DOCS_STAMP := $(VENV)/.installed-docs
$(DOCS_STAMP): $(STAMP)
	$(BIN)/pip install --quiet -e ".[test,docs]"
	touch $(DOCS_STAMP)

# The wall time of a run from scratch is kept for benchmarks/estimate_check.py (ced check's
# run-time estimate against the default study): results/default/wall_seconds.txt.
study: $(STAMP)
	@fresh=$$([ -d results/default/chunks ] && echo 0 || echo 1); start=$$(date +%s); \
	$(BIN)/snakemake --profile workflow/profiles/default --cores $(CORES) && \
	if [ $$fresh = 1 ]; then echo "$$(( $$(date +%s) - start )) $(CORES)" > results/default/wall_seconds.txt; fi
	$(BIN)/snakemake --profile workflow/profiles/default --cores $(CORES) --report results/default/report.html

test: $(STAMP)
	$(BIN)/python -m pytest -q -n $(CORES) tests ced

# -W: a warning fails the build; the gallery's examples run during it.
docs: $(DOCS_STAMP)
	$(BIN)/sphinx-build -W --keep-going -b html docs docs/_build/html
	@echo "open docs/_build/html/index.html"

# Regenerate docs/reference/ from the code (tests/test_docs_reference.py checks it is current).
reference: $(STAMP)
	$(BIN)/python -c 'from ced.cli import write_references; write_references("docs/reference")'

bench: $(STAMP) bench-memory
	$(BIN)/python benchmarks/run.py
	$(BIN)/python benchmarks/steady_state.py
	$(BIN)/python benchmarks/estimate_check.py --cores $(CORES)
	$(BIN)/python benchmarks/six_bar_cost.py
	$(BIN)/python benchmarks/peer/linkages.py
	$(BIN)/python benchmarks/estimate_honesty.py
	$(BIN)/python benchmarks/estimate_sharing.py
	$(BIN)/python benchmarks/study_estimate_check.py
	$(BIN)/python benchmarks/auto_pilots.py
	$(BIN)/python benchmarks/auto_series_check.py
	$(BIN)/python benchmarks/auto_wide_sweeps.py
	@if [ -d results/default/benchmarks ]; then $(BIN)/python benchmarks/study_stages.py; fi

# The reduction's peak memory at 500 and 5,000 cases (benchmarks/reduce_memory.json): flat,
# or the target fails.
bench-memory: $(STAMP)
	$(BIN)/python benchmarks/reduce_memory.py

# Long, needs root: a single-node SLURM on this machine (apt-get slurm-wlm munge), the executor
# plugin pip-installed into .venv, the test study through workflow/profiles/slurm vs. locally.
cluster-test: $(STAMP)
	BIN=$(BIN) tests/cluster/run.sh

clean:
	rm -rf $(VENV) results .snakemake docs/_build docs/api/generated docs/auto_examples
