"""The fluids' lean twins against the readable code (chapter 09): the sparse V-cycle, the face operator.

Each test cites its oracle from ORACLES.md section E; tolerances are in ulps of the quantity compared.
"""

import numpy as np
import pytest

from pbanim.fluids import Grid, solve_cells
from pbanim.fluids.diffusion import FaceOperator
from pbanim.fluids.multigrid import lean_cycle, levels, v_cycle

EPS = np.finfo(float).eps


def _box(shape, boundary, obstacle):
    solid = None
    if obstacle:
        X, Y = Grid(shape, 1.0).positions()
        solid = (X - shape[0] / 2) ** 2 + (Y - shape[1] / 2) ** 2 < (min(shape) / 4) ** 2
    return Grid(shape, 0.1, boundary, solid=solid)


CASES = [((48, 32), "walls", False), ((48, 32), "walls", True), ((32, 24), "periodic", False),
         ((32, 24), ("periodic", "walls"), False), ((16, 12, 12), "walls", False)]


@pytest.mark.parametrize("shape,boundary,obstacle", CASES)
@pytest.mark.parametrize("alpha,beta", [(0.0, 1.0), (1.0, 0.05)])
def test_lean_v_cycle_equals_the_readable_cycle(shape, boundary, obstacle, alpha, beta):
    # ORACLES E24: the sparse red–black V-cycle is the readable one rearranged: equal to a few ulps of the
    # result per level (measured ≤ 5.5 ε max|M b| on these boxes, 3-D with 3 levels; bound 8 ε × levels)
    g = _box(shape, boundary, obstacle)
    hierarchy = levels(g, alpha, beta)
    assert len(hierarchy) >= 2                    # a real cycle: at least one smoothing level
    b = np.random.default_rng(3).standard_normal(g.shape) * g.fluid
    readable, lean = v_cycle(hierarchy, b, alpha, beta), lean_cycle(g, alpha, beta)(b)
    assert np.abs(lean - readable).max() <= 8 * EPS * len(hierarchy) * np.abs(readable).max()
    assert np.array_equal(lean[g.solid], np.zeros(int(g.solid.sum())))
    for lv in lean_cycle(g, alpha, beta).levels[:-1]:      # a two-colouring: the in-place half-sweeps are sound
        nr = lv["n_red"]
        assert lv["M"][:nr, :nr].count_nonzero() == np.count_nonzero(lv["M"].diagonal()[:nr])


def _cycle_every_half_sweep(lc, k, b):
    # LeanCycle._cycle as first written: all 2·SMOOTH pre-smoothing half-sweeps, the first from x = 0 too, and
    # the fine field permuted by a scatter
    # (the coarsest level's direct solve is the cycle's own: no sweep there)
    from pbanim.sparse_kernel import add_csr_product

    lv = lc.levels[k]
    if k == len(lc.levels) - 1:
        return lc._cycle(k, b)
    x, bs = np.zeros(b.size), b / lv["d"]
    pre, post = lv["sweeps"]
    for order in (pre, "coarse", post):
        if order == "coarse":
            x += lv["P"] @ _cycle_every_half_sweep(lc, k + 1, lv["R"] @ (b - lv["M"] @ x))
            continue
        for part, N in order:
            y = x[part]
            y[...] = bs[part]
            add_csr_product(N, x, y)
    return x * lv["fluid"]


@pytest.mark.parametrize("shape,boundary,obstacle", CASES)
@pytest.mark.parametrize("alpha,beta", [(0.0, 1.0), (1.0, 0.05)])
def test_lean_cycle_skips_only_the_product_of_its_zero_start(shape, boundary, obstacle, alpha, beta):
    # ORACLES E24: the lean cycle's first red half-sweep from x = 0, x_R = b_R/a_R + N_R·0, is taken as b_R/a_R
    # (no product), and the field is permuted back by a gather: the cycle with every product and a scatter, bit for bit
    g = _box(shape, boundary, obstacle)
    lc = lean_cycle(g, alpha, beta)
    b = np.random.default_rng(11).standard_normal(g.shape) * g.fluid
    want = np.empty(b.size)
    want[lc.perm] = _cycle_every_half_sweep(lc, 0, b.ravel()[lc.perm])
    assert np.array_equal(lc(b), want.reshape(g.shape))


@pytest.mark.parametrize("method", ["mgpcg", "multigrid"])
def test_lean_and_readable_cycles_solve_alike(method):
    # ORACLES E24, E2: the solve with the lean cycle takes the iterations of the readable one and meets the
    # same tolerance; the two pressures agree to roundoff (measured 6e-16 relative; bound 1e-12)
    g = _box((32, 24), "walls", True)
    b = np.random.default_rng(5).standard_normal(g.shape)
    (p1, i1), (p2, i2) = (solve_cells(g, b, 0.0, 1.0, method, tol=1e-10, lean=lean) for lean in (True, False))
    assert i1.iterations == i2.iterations
    assert max(i1.residual, i2.residual) <= 1e-8 * np.abs(b).max()
    assert np.abs(p1 - p2).max() <= 1e-12 * np.abs(p2).max()


def test_face_operator_is_the_five_point_stencil_with_ghosts():
    # ORACLES E10: A = I − a∇² on the faces of component 0 of a walls box with a sliding lid, against the stencil
    # written out with a padded array: neighbours along x (wall faces held: a mirror of themselves), ghosts
    # 2w − u across the walls in y (bit for bit: the same sums in the same order)
    g = Grid((6, 5), 0.2, "walls", lids={"y+": (1.5, 0.0)})
    A = FaceOperator(g, 0, 0.3)
    x = np.random.default_rng(1).standard_normal(g.face_shape(0))
    lap = -4.0 * x
    lap[1:] += x[:-1]
    lap[:-1] += x[1:]
    lap[0] += x[0]
    lap[-1] += x[-1]
    lap[:, 1:] += x[:, :-1]
    lap[:, :-1] += x[:, 1:]
    lap[:, 0] += 0.0 - x[:, 0]
    lap[:, -1] += 2.0 * 1.5 - x[:, -1]
    np.testing.assert_array_equal(A.laplacian(x, walls=True), lap / g.dx ** 2)
    np.testing.assert_array_equal(A(x), np.where(A.closed, x, x - 0.3 * A.laplacian(x, walls=False)))


@pytest.mark.parametrize("shape,boundary", [((24, 20), "walls"), ((20, 15), "periodic"), ((15, 12), ("periodic", "walls")),
                                            ((8, 6, 7), "walls")])
def test_sparse_face_operator_equals_the_readable_one(shape, boundary):
    # ORACLES E25: the face operator's matrix read off by 2d + 1 probes applies as the readable operator, to a
    # few ulps of the result (measured ≤ 1.8 ε max|A x|; bound 16 ε), on every component, lid or not
    from pbanim.fluids.diffusion import SparseFaceOperator

    lids = {"y+": (1.5,) + (0.0,) * (len(shape) - 1)} if boundary == "walls" else None
    g = Grid(shape, 0.1, boundary, lids=lids)
    for i in range(g.dim):
        A = FaceOperator(g, i, 0.02)
        lean = SparseFaceOperator(A)
        x = np.random.default_rng(i).standard_normal(A.diag.shape)
        assert lean.ok and np.abs(lean(x) - A(x)).max() <= 16 * EPS * np.abs(A(x)).max()
        assert lean.matrix.nnz <= (2 * g.dim + 1) * x.size


def test_sparse_face_operator_refuses_a_probe_that_collides():
    # ORACLES E25: a periodic axis of 14 faces (not a multiple of 5) makes two faces of a stencil share a colour:
    # the probe's check fails and the diffusion keeps the readable operator (its products as before)
    from pbanim.fluids.diffusion import SparseFaceOperator, _face_operator

    g = Grid((10, 14), 0.1, "periodic")
    assert not SparseFaceOperator(FaceOperator(g, 0, 0.02)).ok
    A, _, op, _ = _face_operator(g, 0, 0.02)
    assert op is A


def test_lean_diffusion_solves_as_the_readable_one():
    # ORACLES E25, E10: the lid-driven cavity's viscous solve by CG with the sparse operator takes the readable
    # one's iterations and lands on its answer to roundoff (measured 6e-16 relative; bound 1e-13), both with
    # the diagonal preconditioner
    from pbanim.fluids.diffusion import SparseFaceOperator
    from pbanim.fluids.poisson import _cg

    g = Grid((32, 32), 1 / 32, "walls", lids={"y+": (1.0, 0.0)})
    u = g.close([np.random.default_rng(4).standard_normal(g.face_shape(i)) for i in range(2)])
    for i, c in enumerate(u):
        A = FaceOperator(g, i, 1e-4)
        r = np.where(A.closed, 0.0, c) + A.wall_term()
        (a, ia), (b, ib) = (_cg(op, r, c * g.open[i], 1e-12, 1000, lambda v: v / A.diag, "cg")
                            for op in (SparseFaceOperator(A), A))
        assert ia == ib > 5
        assert np.abs(a - b).max() <= 1e-13 * np.abs(b).max()


@pytest.mark.parametrize("shape,boundary", [((32, 32), "walls"), ((20, 15), "periodic"), ((15, 12), ("periodic", "walls")),
                                            ((8, 6, 7), "walls")])
def test_face_inverse_is_the_operators_inverse(shape, boundary):
    # ORACLES E26: the fast diagonalization (K_ax = V Λ Vᵀ per axis) inverts I − a∇² on a box without obstacles:
    # A(M⁻¹ x) = x to a few ulps × the condition number (measured ≤ 3e-15 max|x|; bound 64 ε max|x| (1 + 4da/Δx²))
    from pbanim.fluids.face_solve import FaceInverse

    lids = {"y+": (1.5,) + (0.0,) * (len(shape) - 1)} if boundary == "walls" else None
    g = Grid(shape, 0.1, boundary, lids=lids)
    for a in (0.02, 2.0):
        for i in range(g.dim):
            A = FaceOperator(g, i, a)
            inv = FaceInverse(A)
            x = np.random.default_rng(i).standard_normal(A.diag.shape)
            x[A.closed] = 0.0
            assert inv.ok
            assert np.abs(A(inv(x)) - x).max() <= 64 * EPS * np.abs(x).max() * (1 + 4 * g.dim * a / g.dx ** 2)


def test_face_inverse_refuses_obstacles():
    # ORACLES E26: a solid cell breaks the Kronecker form: no inverse, the diagonal preconditioner is kept
    from pbanim.fluids.face_solve import FaceInverse

    g = _box((24, 20), "walls", True)
    assert not FaceInverse(FaceOperator(g, 0, 0.02)).ok


def test_diffusion_preconditioned_by_the_inverse_meets_the_same_test():
    # ORACLES E26, E10: the lean diffusion (the exact inverse as CG's preconditioner) stops after one iteration
    # at the readable solve's test ‖r − A x‖₂ ≤ tol ‖r‖₂; both answers are then within 2 tol ‖r‖₂ of each
    # other (‖A⁻¹‖₂ ≤ 1: A = I − a∇² has eigenvalues ≥ 1). Measured 8e-13 against the bound 2.6e-10 (64², lid)
    from pbanim.fluids import diffuse_velocity

    g = Grid((64, 64), 1 / 64, "walls", lids={"y+": (1.0, 0.0)})
    u = g.close([np.random.default_rng(4).standard_normal(g.face_shape(i)) for i in range(2)])
    tol = 1e-12
    (a, ia), (b, ib) = (diffuse_velocity(g, u, 0.01, 0.01, "cg", tol=tol, lean=lean) for lean in (True, False))
    assert [s.iterations for s in ia] == [1, 1] and all(s.iterations > 10 for s in ib)
    for i, (x, y) in enumerate(zip(a, b)):
        A = FaceOperator(g, i, 1e-4)
        r = np.where(A.closed, 0.0, u[i]) + A.wall_term()
        assert np.linalg.norm(r - A(x)) <= tol * np.linalg.norm(r)
        assert np.abs(x - y).max() <= 2 * tol * np.linalg.norm(r)

@pytest.mark.parametrize("method", ["semi_lagrangian", "cubic", "bfecc", "maccormack", "maccormack_unlimited"])
@pytest.mark.parametrize("boundary,obstacle", [("periodic", False), ("walls", True)])
def test_advect_scalar_steps_are_the_steps_one_by_one(method, boundary, obstacle):
    # ORACLES E27: the departure points and their sample coordinates computed once for all the steps under a held
    # u give the states of advect_scalar called step by step, bit for bit (a random u: not a whole-cell shift)
    from pbanim.fluids import advect_scalar, advect_scalar_steps

    g = _box((24, 16), boundary, obstacle)
    rng = np.random.default_rng(4)
    u = [rng.standard_normal(g.face_shape(0)), rng.standard_normal(g.face_shape(1))]
    X, Y = g.positions()
    s0 = np.exp(-((X - 1.2) ** 2 + (Y - 0.8) ** 2) / 0.1) * g.fluid
    s = s0
    for _ in range(6):
        s = advect_scalar(g, s, u, 0.03, method)
    assert np.abs(s - s0).max() > 0.1                      # the field moved
    assert np.array_equal(advect_scalar_steps(g, s0, u, 0.03, 6, method), s)
    assert np.array_equal(advect_scalar_steps(g, s0, u, 0.03, 0, method), s0)


@pytest.mark.parametrize("backtrace", ["euler", "midpoint"])
@pytest.mark.parametrize("method", ["maccormack", "semi_lagrangian"])
def test_scalars_advected_together_are_advected_one_by_one(method, backtrace):
    # ORACLES E28: Advection traces the departure points once for all its scalars (the smoke's density and
    # temperature); lean_path = False advects each by advect_scalar: the runs are equal bit for bit
    from pbanim.fluids import Advection, smoke_plume

    runs = []
    for lean in (True, False):
        scene = smoke_plume((32, 48), advection=method)
        adv = next(st for st in scene.stages if isinstance(st, Advection))
        adv.backtrace, adv.lean_path = backtrace, lean
        res = scene.simulate(0.4, 0.02, frame_every=5, keep=("density", "temperature"))
        runs.append((res.frames["density"], res.frames["temperature"], scene.state.u))
    (d1, t1, u1), (d2, t2, u2) = runs
    assert d1[-1].max() > 0.1 and len(d1) >= 4                 # smoke was carried up
    assert np.array_equal(d1, d2) and np.array_equal(t1, t2)
    assert all(np.array_equal(a, b) for a, b in zip(u1, u2))


@pytest.mark.parametrize("mode", ["wrap", "reflect", "symmetric"])
def test_ghost_layers_by_slices_are_np_pad(mode):
    # ORACLES E29: the ghost layers copied by slices are np.pad's, bit for bit and shape for shape, on every axis
    # of 2-D and 3-D fields, short axes (np.pad's repeated reflections) included
    from pbanim.fluids.interpolate import GHOSTS, _pad

    rng = np.random.default_rng(8)
    for shape in [(3, 5), (4, 7), (5, 2), (9, 8), (33, 48), (6, 4, 5)]:
        q = rng.standard_normal(shape)
        for a in range(len(shape)):
            pad = [(0, 0)] * len(shape)
            pad[a] = (GHOSTS, GHOSTS)
            want = np.pad(q, pad, mode=mode)
            got = _pad(q, pad, mode)
            assert got.shape == want.shape and np.array_equal(got, want), (shape, a)
