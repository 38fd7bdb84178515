"""The body protocol (pbanim/bodies.py): what impulses, constraints and contacts ask of a system."""

import numpy as np
import pytest

from pbanim.collision import Plane
from pbanim.contact import TimeStepping
from pbanim.particles import ParticleSystem
from pbanim.rigid import RigidBodies


def test_body_protocol_members_agree_with_the_physics():
    # an impulse j at p changes u by W Gᵀj (rigid: Δv = j/m, Δω = I⁻¹_world (p − x) × j); ṗ = v + ω × (p − x)
    from pbanim.bodies import Bodies

    rng = np.random.default_rng(0)
    rb = RigidBodies([1.0, 3.0], [[1.0, 2.0, 3.0], [2.0, 2.0, 1.0]], positions=rng.normal(size=(2, 3)),
                     orientations=rng.normal(size=(2, 4)), velocities=rng.normal(size=(2, 3)),
                     angular_velocities=rng.normal(size=(2, 3)))
    ps = ParticleSystem(rng.normal(size=(3, 3)), rng.normal(size=(3, 3)), masses=[1.0, 2.0, 4.0])
    for sysm in (rb, ps):
        assert isinstance(sysm, Bodies)
        y = sysm.state()
        idx = np.array([1, 0, -1])
        p = rng.normal(size=(3, 3))
        j = rng.normal(size=(3, 3))
        y1 = sysm.apply_impulses(y, idx, p, j)
        du = sysm.generalized_velocity(y1) - sysm.generalized_velocity(y)
        G = np.zeros((sysm.N, sysm.dof))        # generalized impulses Gᵀj per body
        x = sysm.unpack(y)[0]
        for i, pi, ji in zip(idx, p, j):
            if i >= 0:
                G[i, :3] += ji[:sysm.dof]
                if sysm.dof == 6:
                    G[i, 3:] += np.cross(pi - x[i], ji)
        np.testing.assert_allclose(du, sysm.apply_inverse_mass(y, G), atol=1e-13)
        np.testing.assert_allclose(sysm.apply_inverse_mass(y, G),
                                   np.einsum("nij,nj->ni", sysm.inverse_mass_blocks(y), G), atol=1e-13)
        u = sysm.generalized_velocity(y)
        pv = sysm.point_velocity(y, idx, p)
        np.testing.assert_array_equal(pv[2], 0.0)            # the world does not move
        expect = u[0, :3] + (np.cross(u[0, 3:], p[1] - x[0]) if sysm.dof == 6 else 0.0)
        np.testing.assert_allclose(pv[1], expect, atol=1e-14)


def test_a_system_without_the_body_protocol_is_named():
    from pbanim.collision import Collisions
    from pbanim.contact import RestingContact
    from pbanim.errors import BodyProtocolError

    class Half:                      # has some members, not the protocol
        N, dof, kind = 1, 3, "particles"

        def generalized_velocity(self, y):
            return y

    for effect, who in ((Collisions(obstacles=[Plane([0, 0, 1])]), "Collisions"),
                        (RestingContact(lambda y: None), "RestingContact")):
        with pytest.raises(BodyProtocolError, match=f"{who} needs a system implementing the body protocol.*Half "
                                                    "lacks inverse_mass_blocks, apply_inverse_mass, point_velocity, "
                                                    "apply_impulses$"):
            effect.bind(Half())
    with pytest.raises(BodyProtocolError, match="TimeStepping needs"):
        TimeStepping(Half(), lambda y: None, [])
