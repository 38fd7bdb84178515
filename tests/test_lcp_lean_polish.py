"""The stepping loop's Lemke polish (pbanim.lcp.lean_solve._polish_lean) is the readable polish (ORACLES D23).

``_polish_lean`` runs pivoting._polish's operations through the gufunc behind ``np.linalg.lstsq`` without its
wrapper: the same f bit for bit, on the LCPs a box on an incline and a stack of boxes pose step by step (warm
starts and Lemke's answers), on redundant contacts (A_CC singular) and on random monotone LCPs.
"""

import numpy as np
import pytest

import pbanim.contact.lean_friction as lean_friction
from pbanim.contact.friction import TimeStepping
from pbanim.lcp.lean_solve import _lstsq, _polish_lean
from pbanim.lcp.pivoting import _lemke, _polish
from pbanim.models.contact import box_on_incline, box_stack


def _same(a, b):
    return a.shape == b.shape and np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b))


def _captured_lcps(monkeypatch, sc, t_end, h):
    """The (A, b, warm start) of every step of a friction run."""
    seen = []
    real = lean_friction.lean_lemke

    def spy(A, b, ws, tol, **opts):
        seen.append((A.copy(), b.copy(), None if ws is None else ws.copy()))
        return real(A, b, ws, tol, **opts)

    monkeypatch.setattr(lean_friction, "lean_lemke", spy)
    ts = TimeStepping(sc.system, sc.detect, sc.forces, friction=0.5, facets=4, lean=True)
    ts.simulate(t_end, h)
    return seen


@pytest.mark.parametrize("which", ["stick", "slide", "stack"])
def test_lean_polish_is_the_readable_polish_along_a_run(monkeypatch, which):
    if which == "stack":
        sc = box_stack(3, 1.0, margin=0.02)
    else:
        sc = box_on_incline(np.arctan(0.5) + (0.1 if which == "slide" else -0.1), 0.5)
    lcps = _captured_lcps(monkeypatch, sc, 0.08, 1e-3)
    assert len(lcps) > 20
    checked = 0
    for A, b, ws in lcps:
        starts = [] if ws is None or ws.size != b.size else [np.where(ws > 0, 1.0, 0.0) * np.maximum(ws, 0)]
        f, status, _ = _lemke(A, b)
        if status == "solved":
            starts.append(f)
        for f0 in starts:
            assert _same(_polish_lean(A, b, f0), _polish(A, b, f0, 1e-10))
            checked += 1
    assert checked > 20


def test_lean_polish_on_redundant_contacts_and_random_lcps():
    rng = np.random.default_rng(7)
    for k in range(300):
        m = int(rng.integers(1, 9))
        J = rng.normal(size=(m, max(1, m - int(rng.integers(0, 3)))))   # fewer columns: A singular, consistent
        A = J @ J.T + (0.0 if k % 2 else 1e-3) * np.eye(m)
        b = rng.normal(size=m)
        f0 = np.maximum(rng.normal(size=m), 0.0) * (rng.random(m) < 0.7)
        assert _same(_polish_lean(A, b, f0), _polish(A, b, f0, 1e-10))


def test_lstsq_is_numpys_and_a_different_answer_is_seen():
    rng = np.random.default_rng(1)
    for n in range(1, 9):
        M = rng.normal(size=(n, n))
        M[:, -1] = M[:, 0] if n > 1 else M[:, -1]                    # rank-deficient for n > 1
        r = rng.normal(size=n)
        assert _same(_lstsq(M, r), np.linalg.lstsq(M, r, rcond=None)[0])
    M, r = rng.normal(size=(4, 4)), rng.normal(size=4)
    # the check can fail: a plain solve of the same system differs from gelsd in the last bits somewhere
    diffs = [not np.array_equal(_lstsq(M + d * np.eye(4), r), np.linalg.solve(M + d * np.eye(4), r))
             for d in np.linspace(0.0, 1.0, 20)]
    assert any(diffs)
