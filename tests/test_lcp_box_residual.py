"""The box-friction active set returns the residual of the answer it returns (ORACLES D26).

``box_friction_active_set`` keeps the residual it computed for its last (z, w) — after an exchange of the
states, when the rounds run out or stop improving — instead of computing it once more on return. The
returned residual must be the readable :func:`box_friction_residual` of the returned z and w = A z + b, bit for
bit: after one round (the design chapter's neighbour descent), after the cap, after the patience stop and
after a converged exchange.
"""

import numpy as np
import pytest

from pbanim.lcp.active_set import box_friction_active_set, box_friction_residual
from pbanim.models.contact import random_contact_lcp


def _problems():
    for seed in range(6):
        case = random_contact_lcp(12, redundant=seed % 2 == 1, seed=seed)     # 4 contacts, 3 rows each
        yield seed, case.A, case.b


@pytest.mark.parametrize("max_iter", [1, 2, 40])
def test_returned_residual_is_the_residual_of_the_returned_answer(max_iter):
    rng = np.random.default_rng(3)
    seen_rounds = set()
    for seed, A, b in _problems():
        for trial in range(6):
            state = None if trial == 0 else np.column_stack([rng.integers(0, 2, 4), rng.integers(-1, 2, (4, 2))])
            for patience in (1, 3):
                z, res, rounds, _ = box_friction_active_set(A, b, 0.5, state=state, max_iter=max_iter,
                                                            tol=1e-10, patience=patience)
                seen_rounds.add(rounds)
                assert res == box_friction_residual(z, A @ z + b, 0.5), (seed, trial, patience)
    assert max(seen_rounds) > 1 or max_iter == 1      # more than one round happened: a stale residual would show
