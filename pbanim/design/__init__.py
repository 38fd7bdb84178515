"""Design of rigid-body motion (chapter 10): S(t, u), ∂S/∂u through impacts, min-norm edits, shooting.

The lecture (Popović, after Popović, Seitz, Erdmann, Z. Popović & Witkin, SIGGRAPH 2000, and Popović,
Seitz & Erdmann, ACM TOG 2003) turns the simulator around. A simulation is a function

    q(t) = S(t, u),      q = (x, r, mv, Iω)  (position, orientation, momenta),

of a parameter vector u (initial position, orientation, linear and angular velocity, and by choice the
restitution ε, masses, inertias and the normals of the environment's planes). Free flight obeys

    d/dt (x, r, mv, Iω) = (v, ½ ω r, F, τ),       and an impact   q⁺ = q⁻ + J(q⁻, m, I, ε, n).

Small changes follow the derivative, δq = (∂S/∂u) δu. The animator says where a body should be
(δq: several positions or orientations, of one or more bodies, at one or more times) and the system
finds the change of u that puts it there with the least effort in the metric M:

    min δuᵀ M δu   subject to   δq = (∂S/∂u) δu     →   δu = M⁻¹Aᵀ(AM⁻¹Aᵀ + λ²𝟙)⁻¹ δq,   A = ∂S/∂u

(λ = 0 when A has full row rank; damped least squares when it does not). Repeating the update while the
mouse drags is the interactive loop. Motion sketching solves a boundary value problem instead: single
shooting optimizes u so that goals C(q(t)) = 0 hold while the motion stays close to a sketch E; multiple
shooting takes the states at grid nodes as unknowns and adds continuity (physics) constraints, with
nodes that slide to follow the impacts.

Notation
--------
==============  =====================  ==========================================================
symbol          code                   meaning
==============  =====================  ==========================================================
u               ``u``, ``names``       parameter vector, a selection of named blocks (``x0``, ...)
S(t, u)         ``simulate``           the simulation function (a :class:`Trajectory`)
∂S/∂u           ``Trajectory.d_*``     sensitivities (positions; orientations in the tangent space)
M               ``M``                  metric of the update (SPD), default 𝟙
δq              goal residuals         target − current, stacked over goals
λ               ``damping``            damped-least-squares parameter
ε               ``restitution``        coefficient of restitution
==============  =====================  ==========================================================

Limiting cases: without impacts S is smooth and ∂x/∂v₀ = t𝟙; at a grazing impact or a tangent touch S is
not differentiable (reported, never silent); a ball whose bounces die out rests on the floor (the Zeno time
of ORACLES D1), never sinks through it; with as many independent goal rows as parameters the min-norm update
is the Newton step δu = A⁻¹δq.

Parts: :mod:`pbanim.design.scene` (the scene, u ↔ names), :mod:`pbanim.design.flight` (free flight and its
variational equations), :mod:`pbanim.design.impact` (impulses and the saltation jump),
:mod:`pbanim.design.exact` (the closed-form flight of spheres: exact S, ∂S/∂u and impact times, the default
where it applies), :mod:`pbanim.design.rest` (resting contact, touches, the certificate),
:mod:`pbanim.design.simulate` (S and ∂S/∂u), :mod:`pbanim.design.trajectory` (its result),
:mod:`pbanim.design.specs` (what the arguments must be), :mod:`pbanim.design.check` (finite
differences with Richardson extrapolation), :mod:`pbanim.design.control` (goals, the min-norm update, edits,
dragging), :mod:`pbanim.design.shooting` (single shooting, clearance, state unknowns),
:mod:`pbanim.design.multiple` (multiple shooting on a sliding time grid started from the sketch),
:mod:`pbanim.design.stepped`, :mod:`pbanim.design.stepped_sim`, :mod:`pbanim.design.stepped_run` (S(t, u) and
∂S/∂u stepped through resting and sliding contact with friction, issue 30), :mod:`pbanim.design.stepped_design`
(designs that need contact: slide and stop, roll into a cup, a die on a chosen face),
:mod:`pbanim.design.stepped_sketch` (the feasible motion nearest an infeasible sketch, and its report),
:mod:`pbanim.design.articulated` (a chain thrown through flight: S(t, u) and ∂S/∂u of an articulated body
from the derivatives of ABA, and a shooting design that puts its tip on a target; issue 31),
:mod:`pbanim.design.sequences` and :mod:`pbanim.design.sequence_flights` (the discrete search over impact
sequences, each solved with its impacts as the nodes of multiple shooting), :mod:`pbanim.design.body_sequences`
and :mod:`pbanim.design.body_flights` (the same search over several spheres: which body hits which plane or
which other body, in which order), :mod:`pbanim.design.sketch_ui`
(the sketching interface: drag the motion, draw a sketch; matplotlib is imported when an editor is made).

References: J. Popović, S. M. Seitz, M. Erdmann, Z. Popović, A. Witkin, "Interactive manipulation of rigid
body simulations", SIGGRAPH 2000; J. Popović, S. M. Seitz, M. Erdmann, "Motion sketching for control of
rigid-body simulations", ACM TOG 22(4), 2003; A. Witkin & M. Kass, "Spacetime constraints", SIGGRAPH 1988;
U. Ascher, R. Mattheij, R. Russell, *Numerical Solution of Boundary Value Problems for ODEs* (1995),
ch. 4 (shooting); R. Stengel, *Optimal Control and Estimation* (1994).
"""

from __future__ import annotations

from .scene import (DesignBody, DesignScene, GrazingImpactWarning, PenetrationError, RestingContactError,
                    TooManyImpacts, UncertifiedTrajectory, UnknownParameter, left_jacobian, xi)
from .flight import FlightModel, augmented_step, flight_rhs, flight_tangent
from .impact import Impact, apply_impact
from .exact import exact_applies, first_impact, flight_map
from .rest import Rest
from .trajectory import Trajectory
from .simulate import quat_log, simulate
from .stepped import ContactScene, StaticBox
from .stepped_run import ContactTrajectory, Switch, replay_chapter7, simulate_contact
from .stepped_design import ContactDesign, design_contact
from .stepped_sketch import SketchFit, fit_sketch
from .sequences import Sequence, SequenceSearch, search_sequences
from .body_sequences import BodySequence, propose_body_sequences, search_body_sequences, solve_body_sequence
from .sketch_ui import SketchEditor
from .articulated import ChainAim, ChainFlight, aim_chain, simulate_chain, thrown_chain

__all__ = ["DesignBody", "DesignScene", "UnknownParameter", "UncertifiedTrajectory", "TooManyImpacts",
           "RestingContactError", "PenetrationError", "GrazingImpactWarning", "left_jacobian", "xi", "FlightModel",
           "flight_rhs", "flight_tangent", "augmented_step", "Impact", "apply_impact", "Trajectory", "Rest",
           "simulate", "quat_log", "flight_map", "first_impact", "exact_applies", "ContactScene", "StaticBox",
           "ContactTrajectory", "Switch", "simulate_contact", "replay_chapter7", "ContactDesign", "design_contact",
           "SketchFit", "fit_sketch", "thrown_chain", "ChainFlight", "ChainAim", "simulate_chain", "aim_chain",
           "Sequence", "SequenceSearch", "search_sequences", "BodySequence", "propose_body_sequences",
           "solve_body_sequence", "search_body_sequences", "SketchEditor"]
