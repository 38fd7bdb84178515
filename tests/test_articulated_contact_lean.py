"""The articulated contact step's lean path (H, C and the points' Jacobians from one evaluation of the link
transforms per step) against the readable step (crba, bias_forces, point_jacobians, each with its own
transforms): the same runs bit for bit (ORACLES I15)."""

import numpy as np
import pytest

from pbanim.articulated import bias_forces, crba
from pbanim.articulated.dynamics import _mass_bias_poses, world_poses
from pbanim.articulated.contact import ArticulatedContact, Staircase, point_jacobians

from pbanim.models.articulated import ragdoll_down_stairs


def _ragdoll(lean: bool) -> ArticulatedContact:
    thrown, stairs = ragdoll_down_stairs()
    stairs = Staircase(rise=stairs.rise, run=stairs.run, steps=stairs.steps, start=stairs.start, risers=True)
    ac = ArticulatedContact(thrown.system, list(zip(thrown.links, thrown.points)), friction=thrown.mu,
                            terrain=stairs, solver="active_set")
    ac.lean_path = lean
    return ac


def test_shared_transforms_give_the_readable_terms():
    # ORACLES I15: H, C and the world poses at random states of the ragdoll, exactly those of crba,
    # bias_forces and world_poses (each of which evaluates the transforms itself)
    tree = _ragdoll(True).tree
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.normal(size=tree.nq)                     # a floating root (unit quaternion, position), 10 hinges
        q[:4] /= np.linalg.norm(q[:4])
        qd = rng.normal(size=tree.nv)
        H, C, poses = _mass_bias_poses(tree, q, qd)
        assert np.array_equal(H, crba(tree, q)) and np.array_equal(C, bias_forces(tree, q, qd))
        Xup, X0, origins = world_poses(tree, q)
        assert all(np.array_equal(a, b) for a, b in zip(poses[0] + poses[1], Xup + X0))
        assert np.array_equal(poses[2], origins)


@pytest.mark.parametrize("t_end", [0.6])
def test_the_lean_ragdoll_run_is_the_readable_run(t_end):
    # ORACLES I15: the ragdoll thrown down the stairs (the chapter's scene; contacts on treads and risers,
    # the active set from the last step's states), both paths from the same start: every recorded state and
    # diagnostic equal bit for bit. The run is chaotic (contacts switch), so a last-bit difference in any
    # step would grow into a visible one within these 300 steps
    runs = [_ragdoll(lean).simulate(t_end, 2e-3, record_every=10) for lean in (False, True)]
    assert np.array_equal(runs[0].y, runs[1].y)
    for key in ("energy", "min_gap"):
        assert np.array_equal(runs[0].diagnostics[key], runs[1].diagnostics[key])
    assert not np.array_equal(runs[1].y[:, 0], runs[1].y[:, -1])          # it moved


def test_point_jacobians_from_poses_are_the_public_ones():
    # ORACLES I15 (and I8's function): the points' Jacobians from given poses equal point_jacobians at q
    from pbanim.articulated.contact import _point_jacobians

    ac = _ragdoll(True)
    q = ac.system.state()[:ac.tree.nq]
    P, J = point_jacobians(ac.tree, q, ac.links, ac.points)
    P2, J2 = _point_jacobians(ac.tree, world_poses(ac.tree, q), ac.links, ac.points)
    assert np.array_equal(P, P2) and np.array_equal(J, J2)
