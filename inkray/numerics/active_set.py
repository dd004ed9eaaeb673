"""Exact active-set solution of small bound-constrained QPs: the dual of (in)equality QPs.

The multiplier problem of ``min 1/2 y^T Q y`` subject to ``C y = b`` and
``C y >= b`` is ``min 1/2 x^T H x - b^T x`` with ``x_i >= 0`` on the
inequality rows and ``H = C Q^-1 C^T`` (Nocedal & Wright, "Numerical
Optimization", 2nd ed., chapter 16.5: active-set methods for convex QP). Both
methods of inkray solve their constraints through it: the depth maps of
Sýkora et al. (CGF 2010) and the stitching of Ink-and-Ray (TOG 2014).
"""

import numpy as np

from inkray.errors import StageError
from inkray.numerics.threads import one_blas_thread

__all__ = ["dual_active_set", "psd_lstsq"]


def psd_lstsq(H, r):
    """Minimum-norm least-squares solution of ``H x = r`` for a symmetric PSD ``H``.

    Parameters
    ----------
    H : (m, m) symmetric positive semi-definite array
    r : (m,) array

    Returns
    -------
    (m,) float array

    Examples
    --------
    >>> import numpy as np
    >>> psd_lstsq(np.array([[1.0, 0.0], [0.0, 0.0]]), np.array([2.0, 3.0])).tolist()
    [2.0, 0.0]
    """
    w, V = np.linalg.eigh(H)
    cut = 1e-12 * max(1.0, w.max(initial=0.0))
    c = V.T @ r
    c = np.where(w > cut, c / np.where(w > cut, w, 1.0), 0.0)
    return V @ c


def dual_active_set(H, b, inequality, *, what="QP", start=None, return_iterations=False):
    """Exact minimizer of the small dual ``1/2 x^T H x - b^T x``, ``x_i >= 0`` where ``inequality``.

    The multiplier problem of any QP ``min 1/2 y^T Q y`` subject to ``C y = b``
    (rows where ``inequality`` is False) and ``C y >= b`` (True), with
    ``H = C Q^-1 C^T``; the primal solution is ``y = Q^-1 C^T x``.

    Parameters
    ----------
    H : (m, m) symmetric positive semi-definite array
    b : (m,) array
    inequality : (m,) bool array
    what : str, default "QP"
        Names the problem in error messages.
    start : (m,) array, optional
        A feasible warm start (``>= 0`` on the inequalities), e.g. the
        multipliers of a smaller working set padded with zeros: rows with a
        positive value start free, which saves most iterations when a
        constraint-generation loop adds a few rows at a time.
    return_iterations : bool, default False
        Also return the number of iterations.

    Returns
    -------
    (m,) float array
        The multipliers (and the iteration count with ``return_iterations``).

    Raises
    ------
    StageError
        When the dual is unbounded (contradictory constraints) or the method
        does not converge.

    Examples
    --------
    >>> import numpy as np
    >>> dual_active_set(np.eye(2), np.array([1.0, -1.0]), np.array([True, True])).tolist()
    [1.0, 0.0]
    """
    with one_blas_thread():  # small matrices: see inkray.numerics.threads
        x, iterations = _active_set(np.asarray(H, float), np.asarray(b, float),
                                    np.asarray(inequality, bool), what, start=start)
    return (x, iterations) if return_iterations else x


def _active_set(H, b, ineq, what="depth QP", start=None):
    """Exact minimizer of ``1/2 x^T H x - b^T x`` s.t. ``x_i >= 0`` where ``ineq``.

    A primal active-set method on the bounds (the inequality multipliers held
    at 0 form the working set). ``H`` may be singular (dependent constraints):
    on a face the step is the Newton step on the range of ``H_FF``, or, when
    the gradient has a component in its null space, a zero-curvature descent
    direction followed to the nearest bound. Where ``H_FF`` is positive
    definite (the usual case) the step comes from a Cholesky factor, far
    cheaper than the eigendecomposition the singular case needs.
    """
    m = len(b)
    x = np.zeros(m)
    fixed = ineq.copy()
    if start is not None:
        x = np.where(ineq, np.maximum(np.asarray(start, float), 0.0), np.asarray(start, float))
        fixed = ineq & (x <= 0.0)
    scale = max(1.0, np.abs(b).max(initial=0.0))
    gtol = 1e-11 * scale
    max_iter = 20 * m + 50
    for it in range(1, max_iter + 1):
        free = ~fixed
        if free.any():
            fi = np.flatnonzero(free)
            g = H[fi] @ x - b[fi]
            step = _cholesky_step(H[np.ix_(fi, fi)], g)
            if step is not None:
                alpha_max = 1.0
            else:
                step, alpha_max = _singular_step(H[np.ix_(fi, fi)], g, gtol)
            block = ineq[fi] & (step < -1e-15 * scale)
            alpha, j = alpha_max, -1
            if block.any():
                ratios = -x[fi[block]] / step[block]
                k = int(np.argmin(ratios))
                if ratios[k] < alpha:
                    alpha, j = max(0.0, float(ratios[k])), int(fi[block][k])
            if not np.isfinite(alpha):
                raise StageError(f"{what}: the dual is unbounded (contradictory constraints "
                                 "that the cycle test missed)")
            x[fi] += alpha * step
            if j >= 0:
                x[j] = 0.0
                fixed[j] = True
                continue
        g = H @ x - b
        cand = fixed & (g < -gtol)
        if not cand.any():
            return x, it
        fixed[int(np.argmin(np.where(cand, g, np.inf)))] = False
    raise StageError(f"{what}: the active-set method did not converge in {max_iter} iterations")


def _cholesky_step(Hff, g):
    """Newton step ``-Hff^-1 g``, or None when ``Hff`` is not safely positive definite."""
    from scipy.linalg import LinAlgError, cho_factor, cho_solve

    try:
        c = cho_factor(Hff, lower=True, check_finite=False)
    except LinAlgError:
        return None
    d = np.abs(np.diag(c[0]))
    if d.min() <= 1e-7 * d.max():  # nearly singular: the eigen path handles it exactly
        return None
    return -cho_solve(c, g, check_finite=False)


def _singular_step(Hff, g, gtol):
    """Step on a face whose ``Hff`` may be singular: Newton on its range, or a
    zero-curvature descent direction when the gradient leaves the range."""
    w, V = np.linalg.eigh(Hff)
    cut = 1e-12 * max(1.0, w.max(initial=0.0))
    rng = w > cut
    c = V.T @ g
    null_g = V[:, ~rng] @ c[~rng]
    if np.abs(null_g).max(initial=0.0) > gtol:
        return -null_g, np.inf
    return -(V[:, rng] @ (c[rng] / w[rng])), 1.0
