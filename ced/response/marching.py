"""March a batch over its periodic step grid: compiled, or the numpy reference loop.

:class:`Marcher` holds one period of terms (:class:`ced.response.period_terms.PeriodTerms`)
and the factorizations of its step matrices, so that every march over them — the shooting's
one period with 3n + 1 columns, then the response over all revolutions — factorizes each
step matrix once. The Newmark family runs in the compiled kernel
(:func:`ced.response.kernels.newmark_march`, or :func:`ced.response.kernels.newmark_march_packed`
where the terms are held packed on their sparsity, :mod:`ced.response.step_pattern`); Houbolt, or ``compiled=False``, runs the numpy
loop :func:`ced.response.integrators.march`, which the kernel is tested against. The
environment variable ``CED_KERNEL=numpy`` makes the numpy loop the default everywhere (to
check a result against it, or where numba is unavailable for a platform).
"""
from __future__ import annotations

import os

import numpy as np

from .integrators import Integrator, NewmarkFamily, State, forced_columns, march
from .kernels import newmark_march, newmark_march_packed
from .period_terms import PeriodTerms, with_sparsity

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
        self.compiled = compiled and isinstance(scheme, NewmarkFamily)
        if self.compiled and terms.pattern is None:  # terms made by hand: find their sparsity
            terms = with_sparsity(terms)
        self.scheme, self.terms, self.h = scheme, terms, np.ascontiguousarray(h, dtype=float)
        self.ok = np.ones(terms.force.shape[0], bool)
        if self.compiled:
            self._allocate(packed=terms.order is not None)

    @property
    def packed(self) -> bool:
        """The compiled march runs on the packed terms (sparse step matrices)."""
        return self.compiled and self._packed

    def _allocate(self, packed: bool) -> None:
        """Factor storage for the packed or the dense kernel (all steps to be factorized)."""
        terms, n = self.terms, self.terms.n
        ncase, period = terms.force.shape[:2]
        self._packed = packed
        self._factored = np.zeros((ncase, period), bool)
        if packed:
            self._lu = np.empty((ncase, period, len(terms.order.lu_idx)))
            self._matrices = tuple(getattr(terms, name) for name in ("mass", "damping",
                                                                       "stiffness"))
            return
        self._lu = np.empty((ncase, period, n, n))
        self._piv = np.empty((ncase, period, n), np.int64)
        self._matrices = tuple(terms.dense(name) for name in ("mass", "damping", "stiffness"))

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
        M, C, K = self._matrices
        damped = C is not None
        ok = self.ok.copy()
        if self._packed:
            refused = np.zeros_like(ok)
            o = self.terms.order
            absent = np.empty((K.shape[0], 0, K.shape[2]))
            newmark_march_packed(M, C if damped else absent, K, self.terms.force, damped,
                                 self.h, s.alpha_m, s.alpha_f, s.beta, s.gamma, n_steps, q, v,
                                 acc, a, record_every, record, self._lu, self._factored, ok,
                                 refused, o.perm, o.rows_ptr, o.rows_idx, o.lu_ptr, o.lu_idx,
                                 o.diagonal, o.lu_source)
            if refused.any():
                # A step matrix far from positive definite (an indefinite stiffness): the
                # whole batch is marched again, densely with partial pivoting.
                self._allocate(packed=False)
                return self.march(state, n_steps, record_every)
        else:
            empty = np.empty((K.shape[0], 0) + K.shape[2:])
            newmark_march(empty if M is None else M, C if damped else empty, K,
                          self.terms.force, damped, self.h, s.alpha_m, s.alpha_f, s.beta,
                          s.gamma, n_steps, q, v, acc, a, record_every, record, self._lu,
                          self._piv, self._factored, ok)
        self.ok = ok
        failed = ~self.ok
        if failed.any():
            singular = failed & np.isfinite(q).all(axis=(1, 2))
            if singular.any():  # as numpy's solve would: the batch is re-run case by case
                raise np.linalg.LinAlgError(
                    f"Singular matrix: the step matrix of case {int(np.argmax(singular))}")
            record[failed] = np.nan  # diverged: the march stopped where q left the floats
        return State(q, v, acc, a), record
