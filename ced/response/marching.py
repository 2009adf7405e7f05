"""March a batch over its periodic step grid: compiled, or the numpy reference loop.

:class:`Marcher` holds one period of terms (:class:`ced.response.period_terms.PeriodTerms`)
and the factorizations of its step matrices, so that every march over them — the shooting's
one period with 3n + 1 columns, then the response over all revolutions — factorizes each
step matrix once. The Newmark family runs in the compiled kernel
(:func:`ced.response.kernels.newmark_march`), on the step matrices' sparsity where they have
one (:mod:`ced.response.step_pattern`); Houbolt, or ``compiled=False``, runs the numpy
loop :func:`ced.response.integrators.march`, which the kernel is tested against. The
environment variable ``CED_KERNEL=numpy`` makes the numpy loop the default everywhere (to
check a result against it, or where numba is unavailable for a platform).
"""
from __future__ import annotations

import os

import numpy as np

from .integrators import Integrator, NewmarkFamily, State, forced_columns, march
from .kernels import newmark_march
from .period_terms import PeriodTerms
from .step_pattern import nonzero_pattern, step_order

__all__ = ["Marcher"]


class Marcher:
    """Marches over ``terms`` with step ``h`` (case,) s.

    Parameters
    ----------
    scheme : NewmarkFamily or Houbolt
    terms : PeriodTerms
    h : (case,) s
    compiled : bool, optional
        Use the compiled kernel where the scheme has one (the Newmark family); default: yes,
        unless ``CED_KERNEL=numpy``.
    """

    def __init__(self, scheme: Integrator, terms: PeriodTerms, h: np.ndarray,
                 compiled: bool | None = None):
        if compiled is None:
            compiled = os.environ.get("CED_KERNEL", "numba") != "numpy"
        self.scheme, self.terms, self.h = scheme, terms, np.ascontiguousarray(h, dtype=float)
        self.compiled = compiled and isinstance(scheme, NewmarkFamily)
        ncase, period, n = terms.stiffness.shape[:3]
        self.order = None
        if self.compiled:
            self._lu = np.empty((ncase, period, n, n))
            self._piv = np.empty((ncase, period, n), np.int64)
            self._factored = np.zeros((ncase, period), np.int8)
            empty = np.empty((ncase, 0, n, n))
            self._M = terms.mass if terms.mass is not None else empty
            self._C = terms.damping if terms.damping is not None else empty
            pattern = terms.pattern
            if pattern is None:
                pattern = nonzero_pattern(terms.mass, terms.damping, terms.stiffness)
            self.order = step_order(pattern)
        self._order_arrays = (tuple(np.asarray(x, np.int64) for x in self.order[:9])
                              if self.order is not None else (np.empty(0, np.int64),) * 9)
        self.ok = np.ones(ncase, bool)

    def columns(self, r: int):
        """The terms with F in column 0 of r columns (``terms`` of the numpy loop)."""
        return forced_columns(self.terms, r)

    def march(self, state: State, n_steps: int, record_every: int = 0) -> tuple[State, np.ndarray]:
        """Advance ``state`` (column layout (case, n, r), F driving column 0) by ``n_steps``.

        Returns the final state and, with ``record_every`` > 0, column 0 of q at every
        ``record_every``-th step from 0 (case, n_record, n); cases whose step matrix is
        singular or whose state stops being finite are False in :attr:`ok` (their values
        are then not to be used).
        """
        ncase, n, r = state.q.shape
        n_record = n_steps // record_every + 1 if record_every else 0
        record = np.zeros((ncase, n_record, n))
        if not self.compiled:
            def keep(k, st):
                if record_every and k % record_every == 0:
                    record[:, k // record_every] = st.q[..., 0]
            with np.errstate(all="ignore"):
                end = march(self.scheme, self.columns(r), self.h, n_steps, state, keep)
            self.ok &= np.isfinite(end.q).all(axis=(1, 2))
            return end, record
        s = self.scheme
        if self.terms.mass is None:
            raise ValueError("the compiled march needs the mass (effect elastic_inertia)")
        q, v, acc, a = (np.array(x, dtype=float, order="C", copy=True)
                        for x in (state.q, state.v, state.acc, state.a))
        newmark_march(self._M, self._C, self.terms.stiffness, self.terms.force,
                      self.terms.damping is not None, self.h, s.alpha_m, s.alpha_f, s.beta,
                      s.gamma, n_steps, q, v, acc, a, record_every, record, self._lu,
                      self._piv, self._factored, self.ok, self._order_arrays)
        failed = ~self.ok
        if failed.any():
            singular = failed & np.isfinite(q).all(axis=(1, 2))
            if singular.any():  # as numpy's solve would: the batch is re-run case by case
                raise np.linalg.LinAlgError(
                    f"Singular matrix: the step matrix of case {int(np.argmax(singular))}")
            record[failed] = np.nan  # diverged: the march stopped where q left the floats
        return State(q, v, acc, a), record
