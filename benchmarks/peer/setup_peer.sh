#!/usr/bin/env bash
# Create the peer venv (benchmarks/.peer-venv, gitignored) and install Exudyn from PyPI into it
# (with scipy, which its eigenvalue solver needs: benchmarks/peer/linkages.py).
# Exudyn is not a dependency of ced: it lives only in this venv. Fails loudly (exit 1) if the
# install or the import fails. Usage: bash benchmarks/peer/setup_peer.sh [python3]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$here/.peer-venv"
python="${1:-python3}"
if [ ! -x "$venv/bin/python" ]; then
    "$python" -m venv "$venv" || { echo "setup_peer: cannot create $venv" >&2; exit 1; }
fi
if ! "$venv/bin/python" -c "import exudyn, numpy, scipy" 2>/dev/null; then
    "$venv/bin/python" -m pip install --quiet --upgrade pip >/dev/null 2>&1 || true
    "$venv/bin/python" -m pip install --quiet "exudyn${EXUDYN_SPEC:-}" numpy scipy \
        || { echo "setup_peer: pip install exudyn failed" >&2; exit 1; }
fi
"$venv/bin/python" -c "import exudyn; print('exudyn', exudyn.__version__)" \
    || { echo "setup_peer: exudyn installed but does not import" >&2; exit 1; }
