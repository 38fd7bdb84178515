"""Engines side by side (chapter 11): the same scenes in pbanim, PyBullet and MuJoCo, against the exact answer.

The lecture ends with "how to start": write your own engine, or start from an existing one (Bullet,
ODE, PhysX, Havok …), and points to comparative studies that ran the same small scenes in each engine
(Boeing & Bräunl 2007; Giovanni & Yin 2011). pbanim knows the closed-form answer of each such scene, so
it can referee: for scene s, engine e and step h,

    error(s, e, h) = ‖observable_e(h) − observable_exact‖  (each scene's own measure, in its own unit)
    cost(s, e, h)  = wall time of the engine's stepping alone (µs per step)
    cost per simulated second = cost(s, e, h) / h   (the same motion: small steps pay here)
    p(s, e)        = d log error / d log h over the sweep (the observed order)

==============  ===============================  ================================================
symbol          code                             meaning
==============  ===============================  ================================================
s               ``SCENES[name]()`` → ``Scene``   a scene described once (``SceneSpec``) + its score
e               ``ENGINES[name]``                pbanim, pybullet, mujoco (``mujoco:RK4``: option)
h               ``Row.h``                        the step (s)
error, cost     ``Row.error``, ``Row.us_per_step``
cost / h        ``Row.s_per_sim_s``              wall s per simulated s (also at the peers' own steps)
p               ``Comparison.order(s, e)``       fitted slope (:func:`pbanim.testing.order_fit`)
==============  ===============================  ================================================

Parts: :mod:`.spec` (scene data, the trace every engine returns, energy and joint drift from a trace),
:mod:`.scenes` (ten scenes and their exact answers), :mod:`.native` (pbanim's translation),
:mod:`.peer_bullet` and :mod:`.peer_mujoco` (the peers' translations, with the parameter-by-parameter
mapping written out), :mod:`.harness` (rows, failures as rows), :mod:`.report` (markdown and JSON).

Peers are optional (``pip install 'pbanim[peers]'``): an engine that is not installed gives rows that
say so, and nothing else changes. ``pbanim compare [SCENE …] [--engines …] [--quick]`` runs it from the
command line.

Limiting cases: free flight is the one scene every engine must get to its integrator's order (ORACLES
K1: semi-implicit Euler in PyBullet and MuJoCo is off by exactly g h t / 2; pbanim's RK4 is exact).

References: A. Boeing, T. Bräunl, "Evaluation of real-time physics simulation systems", GRAPHITE 2007;
S. Giovanni, K. Yin, "LocoTest", Motion in Games 2011; E. Todorov, T. Erez, Y. Tassa, "MuJoCo", IROS
2012; E. Coumans, "Bullet physics", SIGGRAPH 2015 course.
"""

from .harness import ENGINES, OWN_STEPS, Comparison, Engine, Row, check_names, have, run_compare, versions
from .report import as_json, markdown, write
from .scenes import SCENES, Scene, scene, top_precession
from .spec import Body, Joint, SceneSpec, Trace, Unsupported, energy, energy_readable, joint_drift

__all__ = ["ENGINES", "OWN_STEPS", "Engine", "Row", "Comparison", "run_compare", "check_names", "have", "versions",
           "SCENES", "Scene", "scene", "top_precession", "Body", "Joint", "SceneSpec", "Trace", "Unsupported",
           "energy", "energy_readable", "joint_drift", "markdown", "as_json", "write"]
