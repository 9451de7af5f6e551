"""Factorisation of a large sparse symmetric positive definite matrix: MKL PARDISO (``pypardiso``, pinned in
``requirements.txt``), supernodal Cholesky with a METIS nested-dissection ordering, multithreaded.

The interior-point method of ``models/exact/body_space_ipm.py`` factorises matrices of one sparsity pattern with new
values at every iteration: the ordering and symbolic analysis (PARDISO phase 11) are done once per pattern, the
numerical factorisation (phase 22) per matrix, the solves (phase 33, with PARDISO's iterative refinement) per
right-hand side.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

MATRIX_TYPE_SPD = 2  # PARDISO mtype: real symmetric positive definite (upper triangle given)
PHASE_ANALYSIS, PHASE_FACTOR, PHASE_SOLVE, PHASE_RELEASE = 11, 22, 33, -1


class SpdFactorError(RuntimeError):
    """PARDISO refused the matrix (not positive definite, out of memory, ...): the message says which."""


class SpdFactor:
    """``factor(K)`` then ``solve(rhs)``; K symmetric positive definite (only its upper triangle is read)."""

    def __init__(self) -> None:
        from pypardiso import PyPardisoSolver

        self._solver = PyPardisoSolver(mtype=MATRIX_TYPE_SPD)
        self._upper: sp.csr_matrix | None = None
        self._pattern: tuple[np.ndarray, np.ndarray] | None = None
        self.factorizations = 0

    def factor(self, K: sp.spmatrix) -> None:
        upper = sp.triu(K, format="csr")
        upper.sort_indices()
        if self._pattern is None or not (np.array_equal(self._pattern[0], upper.indptr)
                                         and np.array_equal(self._pattern[1], upper.indices)):
            self._call(PHASE_ANALYSIS, upper, np.zeros(upper.shape[0]))
            self._pattern = (upper.indptr.copy(), upper.indices.copy())
        self._call(PHASE_FACTOR, upper, np.zeros(upper.shape[0]))
        self._upper = upper
        self.factorizations += 1

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        if self._upper is None:
            raise SpdFactorError("solve before factor")
        return self._call(PHASE_SOLVE, self._upper, rhs).ravel()

    def release(self) -> None:
        if self._upper is not None:
            self._call(PHASE_RELEASE, self._upper, np.zeros(self._upper.shape[0]))
            self._upper = None
            self._pattern = None

    def _call(self, phase: int, upper: sp.csr_matrix, rhs: np.ndarray) -> np.ndarray:
        from pypardiso.pardiso_wrapper import PyPardisoError

        self._solver._check_A(upper)
        self._solver.set_phase(phase)
        try:
            return self._solver._call_pardiso(upper, np.asfortranarray(rhs, dtype=np.float64))
        except PyPardisoError as exc:
            raise SpdFactorError(f"PARDISO phase {phase} failed on a {upper.shape[0]:,}-unknown matrix with "
                                 f"{upper.nnz:,} upper non-zeros: {exc}") from None
