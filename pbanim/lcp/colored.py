"""Projected Gauss–Seidel for box friction, vectorized by coloring the contacts (chapter 07).

The readable sweep (:func:`pbanim.lcp.solve.pgs_box_friction`) visits the rows one at a time; for
contact i with unknowns zᵢ = (fᵢ, τᵢ₁, τᵢ₂) and w = A z + b,

    fᵢ ← max(0, fᵢ − w_fᵢ / A_ff),   τᵢⱼ ← clip(τᵢⱼ − w_τᵢⱼ / A_ττ, −μ fᵢ, μ fᵢ),   w ← w + A Δz,

which in Python costs a loop iteration per row. Two contacts that share no moving body are decoupled:
their block of A is exactly zero (A = J W Jᵀ and the world's block of W is zero), so updating one does
not change the other's w. A *color* is a set of pairwise decoupled contacts; updating all normals of a
color at once, then all first tangents, then all second tangents is exactly the readable sweep run with
the contacts in color order. One sweep is then a few array operations per color instead of 3m loop
iterations; the answer is the readable one's for that order (``tests/test_lcp_colored.py``).

Coloring: greedy, contacts by decreasing degree, each taking the smallest color its colored neighbours
do not use (Welsh & Powell 1967); at most (largest degree + 1) colors. Coupling is read from A itself
(a nonzero 3 × 3 block), so a dense A (every contact coupled) gives one contact per color — still
Gauss–Seidel, only slower.

=========  ===============  ===========  ==================================================
symbol     code             shape        meaning
=========  ===============  ===========  ==================================================
z          ``z``            (3m,)        impulses [f₁, τ₁₁, τ₁₂, f₂, …]
w          ``w``            (3m,)        A z + b
μ          ``mu``           (m,)         friction coefficient per contact
C_k        ``colors[k]``    (m_k,)       contacts of color k
=========  ===============  ===========  ==================================================

Limiting cases: no two contacts coupled → one color, one sweep is a Jacobi step and is exact for a
diagonal A; all contacts coupled → m colors, the readable sweep.

References: D. J. A. Welsh, M. B. Powell, "An upper bound for the chromatic number of a graph",
Comput. J. 10 (1967); R. Tonge, F. Benevolenski, A. Voroshilov, "Mass splitting for jitter-free
parallel rigid body simulation", SIGGRAPH 2012 (graph coloring of contact solves).
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInput

__all__ = ["contact_colors", "colors_by_bodies", "extend_colors", "pgs_box_friction_colored"]


def contact_colors(A: np.ndarray) -> list[np.ndarray]:
    """Contacts (3 rows each) grouped into colors of pairwise decoupled contacts (a zero 3 × 3 block).

    >>> A = np.eye(9); A[0, 3] = A[3, 0] = 0.5          # contacts 0 and 1 coupled, 2 free
    >>> [c.tolist() for c in contact_colors(A)]
    [[0, 2], [1]]
    """
    n = A.shape[0]
    if A.shape != (n, n) or n % 3:
        raise InvalidInput(f"A must be square with 3 rows per contact, got shape {A.shape}")
    m = n // 3
    coupled = np.abs(A).reshape(m, 3, m, 3).sum(axis=(1, 3)) > 0
    np.fill_diagonal(coupled, False)
    degree = coupled.sum(axis=1)
    color = np.full(m, -1)
    taken = np.zeros(int(degree.max(initial=0)) + 2, dtype=bool)
    for i in np.argsort(-degree, kind="stable").tolist():          # at most m iterations
        used = color[coupled[i]]
        taken[:] = False
        taken[used[used >= 0]] = True
        color[i] = int(np.argmin(taken))                           # the smallest free color
    return [np.flatnonzero(color == c) for c in range(int(color.max(initial=-1)) + 1)]


def colors_by_bodies(a, b, static=()) -> list[np.ndarray]:
    """The same kind of coloring from the contacts' bodies (contact i between bodies a[i] and b[i]; the
    ``static`` ones — the world — couple nothing): greedy edge coloring of the body graph, one bit mask of
    used colors per body, at most 2Δ − 1 colors (Δ the most contacts on one body). O(m) with small
    constants, where :func:`contact_colors` reads an m × m coupling matrix: what a time stepper uses when
    its contacts change from step to step.

    >>> [c.tolist() for c in colors_by_bodies([0, 0, 1], [2, 1, 2], static=[2])]   # body 2: the world
    [[0, 2], [1]]
    """
    a = np.asarray(a, dtype=np.intp).ravel()
    b = np.asarray(b, dtype=np.intp).ravel()
    if a.shape != b.shape:
        raise InvalidInput(f"a and b must have the same length, got {a.size} and {b.size}")
    fixed = {int(k) for k in np.ravel(static)}
    used: dict = {}
    color = np.empty(a.size, dtype=np.intp)
    for i, (p, q) in enumerate(zip(a.tolist(), b.tolist())):        # m iterations
        mask = (0 if p in fixed else used.get(p, 0)) | (0 if q in fixed else used.get(q, 0))
        c = (~mask & (mask + 1)).bit_length() - 1                   # the lowest free color
        color[i] = c
        for k in (p, q):
            if k not in fixed:
                used[k] = used.get(k, 0) | (1 << c)
    n = int(color.max(initial=-1)) + 1
    order = np.argsort(color, kind="stable")
    return np.split(order, np.cumsum(np.bincount(color, minlength=n))[:-1]) if n else []


def extend_colors(a, b, color, static=()) -> np.ndarray:
    """Colors for the contacts whose ``color`` is −1, keeping the others' (contacts persisting from the last
    step): the greedy rule of :func:`colors_by_bodies` run over the new contacts alone, each taking the lowest
    color none of its bodies' contacts holds. The kept colors must already be decoupled (as the last step's
    were); the answer is then decoupled too. One Python iteration per *new* contact: a settled pile keeps
    almost all of its coloring from step to step.

    >>> extend_colors([0, 0, 1], [2, 1, 2], [0, -1, -1], static=[2]).tolist()
    [0, 1, 0]
    """
    a = np.asarray(a, dtype=np.intp).ravel()
    b = np.asarray(b, dtype=np.intp).ravel()
    color = np.array(color, dtype=np.intp).ravel()
    if not (a.shape == b.shape == color.shape):
        raise InvalidInput(f"a, b and color must have the same length, got {a.size}, {b.size}, {color.size}")
    fixed = {int(k) for k in np.ravel(static)}
    kept = np.flatnonzero(color >= 0)
    used: dict = {}
    for p, c in zip(np.concatenate([a[kept], b[kept]]).tolist(), np.concatenate([color[kept]] * 2).tolist()):
        if p not in fixed:
            used[p] = used.get(p, 0) | (1 << c)
    for i in np.flatnonzero(color < 0).tolist():
        p, q = int(a[i]), int(b[i])
        mask = (0 if p in fixed else used.get(p, 0)) | (0 if q in fixed else used.get(q, 0))
        c = (~mask & (mask + 1)).bit_length() - 1
        color[i] = c
        for k in (p, q):
            if k not in fixed:
                used[k] = used.get(k, 0) | (1 << c)
    return color


def color_groups(color) -> list[np.ndarray]:
    """The contacts of each color, in color order (contacts in index order within a color)."""
    color = np.asarray(color, dtype=np.intp)
    n = int(color.max(initial=-1)) + 1
    order = np.argsort(color, kind="stable")
    return np.split(order, np.cumsum(np.bincount(color, minlength=n))[:-1]) if n else []


def pgs_box_friction_colored(A: np.ndarray, b: np.ndarray, mu, *, max_iter: int = 300, tol: float = 1e-8,
                             warm_start=None, colors: list | None = None, validate: bool = True) -> tuple:
    """Colored projected Gauss–Seidel for box friction (see the module docstring).

    Same conditions, arguments and returns as :func:`pbanim.lcp.solve.pgs_box_friction` — (z, residual,
    sweeps), at most ``max_iter`` sweeps — with the contacts visited color by color (``colors`` from
    :func:`contact_colors`, computed when not given; a caller whose contacts persist can pass the last
    step's). A must be symmetric (A = J W Jᵀ): its rows are read in place of its columns.
    ``validate=False`` skips the O(m²) input checks, for a caller that built A and b itself (the time
    stepper); the shapes are still checked.
    """
    from .box import _box_residual, _check, _scale, _warm_impulses

    if validate:
        A, b = _check(A, b)
    n = b.size
    if n % 3 or A.shape != (n, n):
        raise InvalidInput(f"pgs_box_friction_colored needs a square A with 3 rows per contact (normal, two "
                           f"tangents), got A {A.shape}, b {b.shape}")
    m = n // 3
    mu = np.broadcast_to(np.asarray(mu, dtype=float), (m,))
    diag = np.diag(A).copy()
    if np.any(diag <= 0):
        raise InvalidInput("pgs_box_friction_colored needs A with a positive diagonal (add a little regularization)")
    if colors is not None and validate:
        order = np.sort(np.concatenate([np.asarray(K, dtype=np.intp) for K in colors] or [np.zeros(0, np.intp)]))
        if not np.array_equal(order, np.arange(m)):
            raise InvalidInput(f"colors must partition the {m} contacts (each exactly once)")
    z = _warm_impulses(warm_start, n, mu)
    colors = contact_colors(A) if colors is None else colors
    # per color and per row kind: the rows, 1/A_rr, and A's rows (= columns) gathered once
    plan = [(K, [(3 * K + j, 1.0 / diag[3 * K + j], A[3 * K + j]) for j in range(3)]) for K in colors]
    w = A @ z + b
    thresh = tol * _scale(b)
    for sweep in range(1, int(max_iter) + 1):
        for K, kinds in plan:
            for j, (r, inv, rows) in enumerate(kinds):
                if j == 0:
                    new = np.maximum(z[r] - w[r] * inv, 0.0)
                    lim = None
                else:
                    lim = mu[K] * z[3 * K] if lim is None else lim
                    new = np.minimum(np.maximum(z[r] - w[r] * inv, -lim), lim)
                d = new - z[r]
                z[r] = new
                w += d @ rows
        res = _box_residual(z, w, mu)
        if res <= thresh:
            return z, res, sweep
    return z, _box_residual(z, w, mu), int(max_iter)
