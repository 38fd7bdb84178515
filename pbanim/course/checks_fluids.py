"""Checks of ch09_pressure (the pressure projection on the MAC grid) — chapter 09.

In a copy of :mod:`pbanim.fluids.grid` the student writes the three discrete operators the projection is
built from (the module's docstring has them):

    (D u)_c = Σᵢ (uᵢ(c + ½eᵢ) − uᵢ(c − ½eᵢ)) / Δx                 divergence, faces → cells
    (G p)_f = open_f (p(c + eᵢ) − p(c)) / Δx                      gradient, cells → faces (0 on closed faces)
    nb_c   = Σ open_f over the faces of cell c                    the diagonal of −Δx² L, L = D open G

Every check then runs pbanim's own projection stage (:class:`pbanim.fluids.Projection`: −L p = −D u,
u ← u − G p) *on the student's grid*, so the student's D and G decide whether the projection projects;
what comes out is measured with pbanim's reference operators, never with the student's.

=====================  =====================================================================  ======
check                  oracle                                                                 id
=====================  =====================================================================  ======
divergence             D of a linear field is its constant divergence; D of differences of a   E3
                       stream function is 0 (2-D periodic, 3-D walls)
gradient               G of a linear pressure is its slope on open faces, 0 on wall and        E2
                       obstacle faces; G of sin(kx) is 2 cos(kx_f) sin(kΔx/2)/Δx
boundary_counts        open faces per cell: 4 inside, 3 on a wall, 2 in a corner, fewer       E2
                       beside an obstacle (2-D); 3 in a 3-D corner
projection_exact       exact solves (DCT, FFT, sparse LU with an obstacle): ‖D u‖∞ at          E2, E6
                       roundoff, u·n = 0 on closed faces, Π² = Π, ‖Πu‖ ≤ ‖u‖
jacobi_mode            Jacobi sweeps on one Fourier mode: x_k = (1 − f^k) r/λ with              E2
                       f = 1 − ω(1 − (cos θx + cos θy)/2), λ = (4 − 2cos θx − 2cos θy)/Δx²
=====================  =====================================================================  ======

Every grid has Δx ≠ 1, so an operator missing its 1/Δx cannot pass by accident. Limiting cases: a
divergence-free field is its own projection; ω = 1 and θ = (π, π) make Jacobi's factor −1 (the
checkerboard never decays), which is why the check takes a smooth mode.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .registry import CheckFailed, Mutant, array, at_most, attr, check, close

CHECKS: list = []
_EPS = np.finfo(float).eps


def _grids(mod, shape, dx, boundary="walls", solid=None):
    """(student's Grid, pbanim's Grid) with the same cells."""
    from ..fluids.grid import Grid as Reference

    try:
        student = attr(mod, "Grid")(shape, dx=dx, boundary=boundary, solid=solid)
    except CheckFailed:
        raise
    except NotImplementedError:
        raise
    except Exception as exc:  # noqa: BLE001 - the constructor is given code; a student edit may break it
        raise CheckFailed(f"Grid({shape}, dx={dx}, boundary={boundary!r}) raised {type(exc).__name__}: {exc}") from None
    return student, Reference(shape, dx=dx, boundary=boundary, solid=solid)


def _faces(what: str, value, ref) -> list:
    if not isinstance(value, (list, tuple)) or len(value) != ref.dim:
        raise CheckFailed(f"{what} must be a list of {ref.dim} face arrays, got {type(value).__name__}")
    return [array(f"{what}[{i}]", c, ref.face_shape(i)) for i, c in enumerate(value)]


@check(CHECKS, "divergence", 20, "the MAC divergence: exact on linear fields, 0 on a stream function's curl", "E3",
       regions=("Grid.divergence",))
def divergence(mod):
    for shape, dx, slopes in (((5, 4), 0.25, (1.5, -0.5)), ((3, 4, 5), 0.5, (2.0, 0.5, -1.0))):
        g, ref = _grids(mod, shape, dx)
        u = [slopes[i] * ref.positions(i)[i] for i in range(ref.dim)]          # uᵢ = aᵢ xᵢ
        d = array(f"Grid.divergence (grid {shape}, Δx = {dx})", g.divergence([c.copy() for c in u]), shape)
        close(f"D u of u = {slopes}·x (grid {shape}, Δx = {dx})", d, np.full(shape, sum(slopes)), rtol=1e-12,
              unit="1/s", why="differences of a linear field are exact: D u = Σ aᵢ")
    n, dx = 8, 0.125
    g, ref = _grids(mod, (n, n), dx, boundary="periodic")
    psi = np.random.default_rng(3).normal(size=(n, n))                        # ψ at the corners (i, j)Δx
    u = [(np.roll(psi, -1, axis=1) - psi) / dx, -(np.roll(psi, -1, axis=0) - psi) / dx]
    d = array("Grid.divergence of a stream function's curl", g.divergence(u), (n, n))
    # E3: exactly 0 up to the rounding of the differences: measured 5.7e-14 (|u| ≈ 47 m/s), bound 5e-13
    close("D u of u = (∂ψ/∂y, −∂ψ/∂x) (periodic 8×8)", d, np.zeros((n, n)), atol=5e-13, unit="1/s",
          why="the two mixed differences of ψ cancel in D (periodic wrap-around included)")
    return "D exact on linear fields (2-D, 3-D walls) and 0 on a discrete curl (periodic)"


@check(CHECKS, "gradient", 20, "the MAC gradient: slope on open faces, 0 on wall and obstacle faces", "E2",
       regions=("Grid.gradient",))
def gradient(mod):
    solid = np.zeros((6, 5), bool)
    solid[2:4, 2] = True
    g, ref = _grids(mod, (6, 5), 0.2, solid=solid)
    c = (0.7, -1.3)
    x, y = ref.positions()
    G = _faces("Grid.gradient(p)", g.gradient(c[0] * x + c[1] * y), ref)
    for i in range(2):
        close(f"G p on the faces of axis {'xy'[i]} (p = 0.7 x − 1.3 y, an obstacle inside)", G[i],
              c[i] * ref.open[i], rtol=1e-12, unit="Pa/m",
              why="the slope on open faces, 0 on wall faces and on faces touching an obstacle (u·n = 0 there)")
    n, dx = 8, 0.3
    g, ref = _grids(mod, (n, 3), dx, boundary="periodic")
    k = 2 * np.pi * 2 / (n * dx)
    x, _ = ref.positions()
    xf = ref.positions(0)[0]
    G = _faces("Grid.gradient(p)", g.gradient(np.sin(k * x)), ref)
    close("G p of p = sin(kx) on the x faces (periodic)", G[0], 2 * np.cos(k * xf) * np.sin(k * dx / 2) / dx,
          rtol=1e-12, unit="Pa/m", why="(sin k(x_f + Δx/2) − sin k(x_f − Δx/2))/Δx, the face between two cells")
    close("G p of p = sin(kx) on the y faces", G[1], np.zeros_like(G[1]), atol=1e-12, unit="Pa/m")
    return "G exact on walls, an obstacle and a periodic box"


@check(CHECKS, "boundary_counts", 15, "open faces per cell at walls, corners and obstacles (diagonal of −Δx²L)",
       "E2", public=False, regions=("Grid.neighbours",))
def boundary_counts(mod):
    solid = np.zeros((5, 4), bool)
    solid[2, 1] = True
    g, _ = _grids(mod, (5, 4), 0.5, solid=solid)
    want = np.array([[2, 3, 3, 2], [3, 3, 4, 3], [2, 0, 3, 3], [3, 3, 4, 3], [2, 3, 3, 2]], float)
    nb = array("Grid.neighbours()", g.neighbours(), (5, 4))
    nb[solid] = 0.0                                            # a solid cell's count is not used
    close("open faces per cell (walls, one obstacle at (2, 1))", nb, want, atol=0.0,
          why="a wall face and a face touching an obstacle are closed: 2 in corners, 3 on walls, 4 inside")
    g, _ = _grids(mod, (3, 4, 5), 0.5)
    nb = array("Grid.neighbours() (3-D)", g.neighbours(), (3, 4, 5))
    close("open faces of the 3-D corner, edge, face and inner cells", nb[[0, 0, 0, 1], [0, 0, 1, 1], [0, 1, 1, 1]],
          [3, 4, 5, 6], atol=0.0)
    gp, _ = _grids(mod, (4, 3), 0.5, boundary="periodic")
    close("open faces on a periodic box", array("Grid.neighbours() (periodic)", gp.neighbours(), (4, 3)),
          np.full((4, 3), 4.0), atol=0.0)
    return "2/3/4 open faces in 2-D corners/walls/inside, fewer beside an obstacle; 3-D and periodic"


def _project(grid, u, method):
    from ..fluids import Projection

    stage = Projection(method)
    state = SimpleNamespace(u=[c.copy() for c in u], scalars={})
    stage.bind(grid, state)
    stage.apply(grid, state, 0.01)
    return state.u


@check(CHECKS, "projection_exact", 25, "the exact projection leaves roundoff divergence, u·n = 0, Π² = Π, no energy",
       "E2", regions=("Grid.divergence", "Grid.gradient"))
def projection_exact(mod):
    rng = np.random.default_rng(5)
    solid = np.zeros((12, 10), bool)
    solid[4:7, 3:6] = True
    worst = 0.0
    for shape, boundary, obst, method in (((12, 10), "walls", None, "dct"), ((10, 8), "periodic", None, "fft"),
                                          ((12, 10), "walls", solid, "direct")):
        g, ref = _grids(mod, shape, 0.1, boundary, obst)
        u = ref.close([rng.normal(size=ref.face_shape(i)) for i in range(ref.dim)])
        d0 = float(np.abs(ref.divergence(u)).max())
        pu = _faces(f"the projected velocity ({method})", _project(g, u, method), ref)
        d = float(np.abs(ref.divergence(pu)).max())
        worst = max(worst, d / d0)
        # E2's tolerance ‖D u‖∞ ≤ 1e3 ε ‖D u₀‖∞; the reference: measured ≤ 1.7e-15 ‖D u₀‖∞ (‖D u₀‖∞ ≈ 50 / s)
        at_most(f"‖D Πu‖∞ / ‖D u‖∞ ({shape}, {boundary}, {method})", d / d0, 1e3 * _EPS,
                why="u ← u − G p with −L p = −D u leaves only the solve's roundoff (measured with pbanim's D)")
        for i in range(ref.dim):
            close(f"u·n on closed faces of axis {'xy'[i]} ({method})", pu[i][ref.open[i] == 0], np.zeros(
                int((ref.open[i] == 0).sum())), atol=0.0, unit="m/s", why="walls and obstacles: no flow through")
        e0, e1 = ref.kinetic_energy(u), ref.kinetic_energy(pu)
        at_most(f"E(Πu) − E(u) ({method})", e1 - e0, 1e-12 * e0, "J", why="the projection never adds energy (E6)")
        ppu = _faces(f"the velocity projected twice ({method})", _project(g, pu, method), ref)
        scale = max(float(np.abs(c).max()) for c in pu)
        # Π² = Π: the reference measures ≤ 3.2e-15 of max|Πu|; bound 3e-14
        close(f"Π²u − Πu ({method})", np.concatenate([c.ravel() for c in ppu]),
              np.concatenate([c.ravel() for c in pu]), atol=3e-14 * scale, unit="m/s",
              why="a projection: projecting twice changes nothing")
    return f"3 exact projections: worst ‖DΠu‖/‖Du‖ = {worst:.1e}; closed faces, Π² = Π and E(Πu) ≤ E(u) hold"


@check(CHECKS, "jacobi_mode", 20, "Jacobi sweeps shrink a Fourier mode's error by the predicted factor", "E2",
       public=False, regions=("Grid.divergence", "Grid.gradient", "Grid.neighbours"))
def jacobi_mode(mod):
    from ..fluids.poisson import solve_cells

    n, dx, omega, sweeps = 16, 0.05, 0.8, 7
    g, _ = _grids(mod, (n, n), dx, boundary="periodic")
    tx, ty = 2 * np.pi * 1 / n, 2 * np.pi * 2 / n
    i, j = np.indices((n, n))
    r = np.cos(tx * i + ty * j)
    lam = (4 - 2 * np.cos(tx) - 2 * np.cos(ty)) / dx ** 2               # −L on the mode
    f = 1 - omega * (1 - (np.cos(tx) + np.cos(ty)) / 2)
    x, _ = solve_cells(g, r, 0.0, 1.0, "jacobi", iterations=sweeps, omega=omega)
    want = (1 - f ** sweeps) * r / lam
    # E2's tolerance rtol 1e-10; the reference: measured 1.6e-15 of max|x|
    close(f"x after {sweeps} Jacobi sweeps (ω = {omega}, θ = (2π/16, 4π/16), Δx = {dx})",
          array("the Jacobi iterate", x, (n, n)), want, rtol=1e-10, unit="Pa",
          why=f"each sweep multiplies the error by f = 1 − ω(1 − (cos θx + cos θy)/2) = {f:.4f} (diagonal nb/Δx²)")
    return f"Jacobi factor f = {f:.4f} per sweep reproduced"


MUTANTS = (
    Mutant("gradient_sign", "the gradient with the wrong sign: the projection adds G p instead of subtracting it",
           (("g = p - np.roll(p, 1, axis=i)", "g = np.roll(p, 1, axis=i) - p"),
            ("g[tuple(inner)] = np.diff(p, axis=i)", "g[tuple(inner)] = -np.diff(p, axis=i)")),
           ("gradient", "projection_exact", "jacobi_mode")),
    Mutant("divergence_without_dx", "Δx missing from the divergence (L = D G then misses a Δx of its Δx²)",
           (("        return div / self.dx\n", "        return div\n"),),
           ("divergence", "projection_exact", "jacobi_mode")),
    Mutant("obstacle_faces_open", "the gradient is not zeroed on closed faces: flow through obstacles",
           (("out[i] = g * (self.open[i] / self.dx)", "out[i] = g / self.dx"),),
           ("gradient", "projection_exact")),
    Mutant("walls_counted_open", "boundary cells wrong: every cell counted with 2·d open faces",
           (("s += o[tuple(lo)] + o[tuple(hi)]", "s += 2.0"),
            ("s += o + np.roll(o, -1, axis=i)", "s += 2.0")),
           ("boundary_counts",)),
)
