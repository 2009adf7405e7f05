"""Imported first by every benchmark: one BLAS thread, so that ced and the peer are timed
alike (single-threaded) and ratios measured in one run do not depend on the core count.

The variables must be set before numpy is imported; importing this module does it.
"""
import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")
