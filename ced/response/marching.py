"""March a batch over its periodic step grid: compiled, or the numpy reference loop.

:class:`Marcher` holds one period of terms (:class:`ced.response.period_terms.PeriodTerms`)
and the factorizations of its step matrices, so that every march over them — the shooting's
one period with 3n + 1 columns, then the response over all revolutions — factorizes each
step matrix once. The Newmark family runs in the compiled kernel
(:func:`ced.response.kernels.newmark_march`, or
:func:`ced.response.kernels.newmark_march_packed` where the terms are held packed on their
sparsity, :mod:`ced.response.step_pattern`); Houbolt, or ``compiled=False``, runs the numpy
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
            ncase, period = terms.force.shape[:2]
            if terms.order is not None:
                self._lu = np.empty((ncase, period, len(terms.order.lu_idx)))
                self._factored = np.zeros((ncase, period), bool)
            self._set_dense(np.full(ncase, terms.order is None))

    @property
    def packed(self) -> bool:
        """The compiled march runs on the packed terms (sparse step matrices) for some cases."""
        return self.compiled and self.terms.order is not None and not self.dense_cases.all()

    @property
    def dense_cases(self) -> np.ndarray:
        """(case,) bool: the cases marched on dense matrices with pivoting (all of them where
        the step matrices are not sparse; else those a step matrix of which the LU without
        pivoting refused)."""
        return self._dense

    def _set_dense(self, dense: np.ndarray) -> None:
        """Dense terms and factor storage for the cases ``dense`` (all steps to be
        factorized again)."""
        terms, n = self.terms, self.terms.n
        period = terms.force.shape[1]
        self._dense = dense
        if dense.all() and terms.order is None:  # the terms themselves: no copy
            cases = slice(None)
            self._dense_matrices = tuple(getattr(terms, k) for k in ("mass", "damping",
                                                                     "stiffness"))
        else:
            cases = np.flatnonzero(dense)
            self._dense_matrices = tuple(terms.dense(k, cases=cases)
                                         for k in ("mass", "damping", "stiffness"))
        self._dense_index = cases
        size = len(terms.force[cases])
        self._dense_lu = np.empty((size, period, n, n))
        self._piv = np.empty((size, period, n), np.int64)
        self._dense_factored = np.zeros((size, period), bool)

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
        ok = self.ok.copy()
        if self.packed:
            refused = np.zeros_like(ok)
            ok_packed = ok & ~self._dense  # the dense cases are not marched here
            o, (M, C, K) = self.terms.order, (getattr(self.terms, k) for k in
                                              ("mass", "damping", "stiffness"))
            newmark_march_packed(M, _or_absent(C, K), K, self.terms.force, C is not None,
                                 self.h, s.alpha_m, s.alpha_f, s.beta, s.gamma, n_steps, q, v,
                                 acc, a, record_every, record, self._lu, self._factored,
                                 ok_packed, refused, o.perm, o.rows_ptr, o.rows_idx, o.lu_ptr,
                                 o.lu_idx, o.diagonal, o.lu_source)
            if refused.any():
                # A step matrix far from positive definite (a buckled link's indefinite
                # stiffness): that case is marched from the start densely, with pivoting.
                self._set_dense(self._dense | refused)
            ok = np.where(self._dense, ok, ok_packed)
        if self._dense.any():
            ok = self._march_dense(state, n_steps, record_every, q, v, acc, a, record, ok)
        self.ok = ok
        failed = ~self.ok
        if failed.any():
            singular = failed & np.isfinite(q).all(axis=(1, 2))
            if singular.any():  # as numpy's solve would: the batch is re-run case by case
                raise np.linalg.LinAlgError(
                    f"Singular matrix: the step matrix of case {int(np.argmax(singular))}")
            record[failed] = np.nan  # diverged: the march stopped where q left the floats
        return State(q, v, acc, a), record

    def _march_dense(self, state, n_steps, record_every, q, v, acc, a, record, ok):
        """March the dense cases from ``state`` into q, v, acc, a, record (in place); their
        ``ok`` updated."""
        s, cases = self.scheme, self._dense_index
        M, C, K = self._dense_matrices
        if isinstance(cases, slice):  # every case, on the terms themselves
            parts = (q, v, acc, a, record, ok, self.h, self.terms.force)
        else:
            parts = tuple(np.ascontiguousarray(x[cases]) for x in (
                state.q, state.v, state.acc, state.a, record, ok, self.h, self.terms.force))
        qd, vd, accd, ad, recd, okd, h, F = parts
        newmark_march(_or_absent(M, K), _or_absent(C, K), K, F, C is not None, h, s.alpha_m,
                      s.alpha_f, s.beta, s.gamma, n_steps, qd, vd, accd, ad, record_every,
                      recd, self._dense_lu, self._piv, self._dense_factored, okd)
        if not isinstance(cases, slice):
            for whole, part in zip((q, v, acc, a, record, ok), parts):
                whole[cases] = part
        return ok


def _or_absent(x: np.ndarray | None, like: np.ndarray) -> np.ndarray:
    """``x``, or an empty array of ``like``'s kind standing for an absent term (the kernels
    take a flag beside it)."""
    return x if x is not None else np.empty((like.shape[0], 0) + like.shape[2:])
