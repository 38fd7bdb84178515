"""Chapter 10, issue 30: ∂S/∂u through resting and sliding contact. S(t, u) is stepped by chapter 07's
velocity-level contact with box friction (pbanim.design.stepped); ∂S/∂u comes from the complementarity
system differentiated on its active set (ORACLES L2), equals Richardson differences of S where no contact
changes its mode (H2), flags a switch instead of returning a one-sided value, and a bouncing ball comes to
rest at the Zeno time by the step law (L3)."""

import numpy as np
import pytest

from pbanim.collision import Box, Plane, Sphere
from pbanim.design import DesignBody
from pbanim.design.stepped import ContactScene
from pbanim.design.stepped_run import replay_chapter7, simulate_contact

G = 9.81


def richardson(scene, t_end, names, u, h, deltas):
    """(4 D(δ/2) − D(δ))/3 of the final position, one column per parameter (ORACLES H2)."""
    def S(uu):
        return simulate_contact(scene, t_end, names, uu, h=h, sensitivities=False).position(t_end)
    cols = []
    for k, d in enumerate(deltas):
        e = np.zeros(u.size)
        e[k] = d
        D1 = (S(u + e) - S(u - e)) / (2 * d)
        D2 = (S(u + e / 2) - S(u - e / 2)) / d
        cols.append((4 * D2 - D1) / 3)
    return np.array(cols).T


def fd_steps(tr, u):
    """A difference step per parameter inside the interval where the active set is constant: a tenth of the
    distance to the nearest predicted switch, at most 1e-4·max(1, |u_k|)."""
    d = np.array([1e-4 * max(1.0, abs(v)) for v in u])
    for s in tr.switches:
        d[s.index] = min(d[s.index], 0.1 * abs(s.delta))
    return d


def sliding_box(v0=2.0, mu=0.4, z=0.05):
    return ContactScene(DesignBody(Box([0.2, 0.1, 0.05]), position=[0, 0, z], velocity=[v0, 0.3, 0]),
                        [Plane()], friction=mu)


CASES = {
    # a box pushed over the floor: four corners sliding, four separating
    "sliding box": (sliding_box(z=0.052), 0.25, ["x0", "v0", "friction"], {"sliding", "separating"}),
    # a sphere thrown spinning: it slides, then rolls (its contact sticks)
    "rolling sphere": (ContactScene(DesignBody(Sphere(0.1), position=[0, 0, 0.1], velocity=[1.0, 0, 0],
                                               angular_velocity=[0, 3.0, 0]), [Plane()], friction=0.3),
                       0.3, ["v0", "omega0", "friction"], {"sticking", "sliding"}),
    # a tumbling box dropped on the floor: corners separate, hit and slide
    "tumbling box": (ContactScene(DesignBody(Box([0.2, 0.1, 0.05]), position=[0, 0, 0.3], velocity=[1.0, 0, 0],
                                             angular_velocity=[1.0, 2.0, 0.5]), [Plane()], friction=0.5),
                     0.25, ["x0", "omega0"], {"separating", "sliding"}),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_dS_du_equals_richardson_differences_on_a_constant_active_set(case):
    # ORACLES L2, H2: implicit differentiation of the box-friction system on its active set, per contact
    # sticking (A δz = −δw), sliding (δτ = σ(μδλ + λδμ)) or separating (δz = 0), equals the Richardson
    # difference of S with steps inside the interval where no contact changes its mode: 1e-6 relative
    # (measured 2e-12 sliding box, 7e-13 rolling sphere)
    scene, T, names, modes = CASES[case]
    u = scene.vector(names)
    tr = simulate_contact(scene, T, names, u, h=0.005)
    assert tr.differentiable and not tr.notes
    counts = tr.mode_counts()
    assert {k for k, v in counts.items() if v > 0} >= modes, counts
    J = tr.d_position(T)
    F = richardson(scene, T, names, u, 0.005, fd_steps(tr, u))
    assert np.abs(J - F).max() <= 1e-6 * max(1.0, np.abs(F).max()), np.abs(J - F).max()


def test_a_switch_is_flagged_with_its_parameter_never_silent():
    # ORACLES L2: at a switch the two one-sided differences differ and the result says so: at_switch, a note
    # naming the parameter and the value where the mode changes. A sphere thrown sliding starts rolling (its
    # contact sticks) in some step; u is moved onto the predicted switch of v0[0], where that step changes
    # (one Newton move: the slack is linear in v0[0]); the one-sided slopes differ by 1.4e-3 there
    scene = ContactScene(DesignBody(Sphere(0.1), position=[0, 0, 0.1], velocity=[1.0, 0, 0]), [Plane()],
                         friction=0.3)
    T, names = 0.3, ["v0"]
    u = scene.vector(names)
    tr = simulate_contact(scene, T, names, u, h=0.005)
    assert tr.differentiable
    sw = next(s for s in tr.switches if s.index == 0)
    assert sw.kind == "slip → stick" and abs(sw.delta) > 1e-3
    u[0] = sw.value
    tr = simulate_contact(scene, T, names, u, h=0.005, switch_tol=1e-7)
    assert tr.at_switch and not tr.differentiable
    assert any("v0[0]" in n and "one-sided" in n and f"{sw.value:.6f}"[:6] in n for n in tr.notes), tr.notes
    d = 1e-6

    def S(v):
        w = u.copy()
        w[0] = v
        return simulate_contact(scene, T, names, w, h=0.005, sensitivities=False).position(T)[0]
    right, left = (S(u[0] + d) - S(u[0])) / d, (S(u[0]) - S(u[0] - d)) / d
    assert abs(right - left) > 5e-4, (left, right)


def test_box_sliding_to_a_stop_distance_and_its_derivatives():
    # ORACLES L2: a box pushed at v₀ on a plane decelerates at μg and stops at v₀²/(2μg); d/dv₀ = v₀/(μg),
    # d/dμ = −v₀²/(2μ²g) — to the step's resolution: relative 2μgh/v₀ (measured 1.0e-2, 9e-3, 9e-3 at h = 5 ms)
    v0, mu, h, T = 2.0, 0.4, 0.005, 0.6
    scene = ContactScene(DesignBody(Box([0.2, 0.1, 0.05]), position=[0, 0, 0.05], velocity=[v0, 0, 0]),
                         [Plane()], friction=mu)
    tr = simulate_contact(scene, T, ["v0", "friction"], h=h)
    v, _ = tr.velocities(T)
    assert np.abs(v).max() < 1e-9 and tr.differentiable
    J = tr.d_position(T)
    rel = 2 * mu * G * h / v0
    for got, want in [(tr.position(T)[0], v0 ** 2 / (2 * mu * G)), (J[0, 0], v0 / (mu * G)),
                      (J[0, 3], -v0 ** 2 / (2 * mu ** 2 * G))]:
        assert abs(got - want) <= rel * abs(want), (got, want)
    # the independent replay: chapter 07's own FrictionStepping on the same grid (its contacts from its own
    # box–plane narrow phase): the same final state to the compliance κ (measured 2e-9)
    Y = replay_chapter7(scene, T, ["v0", "friction"], h=h)
    assert np.abs(Y[-1, :3] - tr.y[-1, :3]).max() < 1e-7


@pytest.mark.parametrize("eps", [0.5, 0.7])
def test_bouncing_ball_comes_to_rest_at_the_zeno_time_and_stays_above_the_floor(eps):
    # ORACLES L3: dropped from h₀ with restitution ε, the ball rests from t∞ = √(2h₀/g)(1 + ε)/(1 − ε): the
    # step law stops the bounces once the approach speed falls below v_rest = 3gh (no accumulation of
    # bounces), which cuts the tail of the Zeno series by at most (2v_rest/g)(1+ε)/(1−ε)·… ≤ 6h(1+ε)/(1−ε);
    # measured −0.3h (ε = 0.5) and −14h (ε = 0.7) at h = 2 ms. After t∞ the ball stays on the floor: its
    # height is the radius to the contacts' compliance (measured 7e-10 m)
    r, h0, h = 0.1, 1.0, 0.002
    scene = ContactScene(DesignBody(Sphere(r), position=[0, 0, r + h0]), [Plane()], friction=0.5, restitution=eps)
    t_inf = np.sqrt(2 * h0 / G) * (1 + eps) / (1 - eps)
    tr = simulate_contact(scene, t_inf + 0.3, ["x0"], h=h, sensitivities=False)
    on = tr.modes[:, 0] != 0
    t_rest = tr.t[np.flatnonzero(~on)[-1] + 1]
    assert abs(t_rest - t_inf) <= 6 * h * (1 + eps) / (1 - eps) + 2 * h, (t_rest, t_inf)
    z = tr.positions()[:, 2] - r
    assert z.min() > -1e-8
    after = tr.t > t_rest
    assert np.abs(z[after]).max() < 1e-8 and np.all(on[np.flatnonzero(after)[:-1]])
