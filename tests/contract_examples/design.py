"""Valid calls for pbanim.design (chapter 10): a ball above a floor, small enough that each call is quick."""

import numpy as np

from pbanim.collision import Plane, Sphere
from pbanim.design import DesignBody, DesignScene, FlightModel, Trajectory, simulate
from pbanim.design.impact import Features
from pbanim.design.stepped import ContactScene
from pbanim.design.stepped_run import ContactTrajectory, simulate_contact


def _contact_goal():
    from pbanim.design.control import position_goal

    return position_goal(0, 0.2, [0.2, 0.0, 0.1])


def _contact_scene():
    """A ball on the floor, pushed sideways (the stepped contact model of issue 30)."""
    return ContactScene(DesignBody(Sphere(0.1), position=[0.0, 0.0, 0.1], velocity=[0.5, 0.0, 0.0]),
                        [Plane([0.0, 0.0, 1.0])], friction=0.3)


def _body():
    return DesignBody(Sphere(0.1), position=[0.0, 0.0, 1.1], velocity=[0.5, 0.0, 0.0])


def _scene():
    return DesignScene([_body()], [Plane([0.0, 0.0, 1.0])], gravity=[0.0, 0.0, -10.0], restitution=0.5)


def _model():
    """The flight model of the ball with two parameters (p = 2)."""
    return FlightModel(1, np.array([1.0]), np.array([1.0]), np.full((1, 3), 250.0), np.array([0.0, 0.0, -10.0]),
                       np.zeros((2, 1)), np.zeros((2, 1)), np.zeros((2, 1, 3)))


def _falling_state():
    """The ball at the floor (gap 0), falling at 3 m/s: an impact of feature 0."""
    y = np.zeros(13)
    y[:3], y[3:7], y[7:10] = [0.0, 0.0, 0.1], [1.0, 0.0, 0.0, 0.0], [0.5, 0.0, -3.0]
    return y


def _trajectory():
    return simulate(_scene(), 1.0, ["x0", "v0"], times=[0.5], h=0.25, warn=False)


INSTANCES = {
    DesignBody: _body,
    DesignScene: _scene,
    FlightModel: _model,
    Features: lambda: Features(_scene()),
    Trajectory: _trajectory,
    ContactScene: lambda: _contact_scene(),
    ContactTrajectory: lambda: simulate_contact(_contact_scene(), 0.2, ["v0"], times=[0.1], h=0.05),
}

_AT = {"t": 0.5}
CALLS = {
    # every field given: the dataclass's default factories are not values the fuzz can pass on
    "pbanim.design.scene.DesignBody.__init__": lambda: {
        "shape": Sphere(0.1), "position": np.array([0.0, 0.0, 1.1]), "orientation": np.array([1.0, 0.0, 0.0, 0.0]),
        "velocity": np.zeros(3), "angular_velocity": np.zeros(3), "inertia": np.full(3, 0.004)},
    "pbanim.design.scene.DesignScene.__init__": lambda: {"bodies": [_body()], "planes": [Plane([0.0, 0.0, 1.0])]},
    "pbanim.design.simulate.simulate": lambda: {"scene": _scene(), "t_end": 0.6, "h": 0.1, "max_steps": 2000},
    "pbanim.design.impact.apply_impact": lambda: {"y": _falling_state(), "normals": np.array([[0.0, 0.0, 1.0]]),
                                                  "k": 0, "t": 0.0},
    "pbanim.design.exact.first_impact": lambda: {"y": _falling_state() + np.r_[0, 0, 1.0, np.zeros(10)],
                                                 "normals": np.array([[0.0, 0.0, 1.0]]), "tol": 1e-9},
    **{f"pbanim.design.trajectory.Trajectory.{m}": (lambda: dict(_AT)) for m in
       ("position", "orientation", "d_position", "d_orientation", "velocities", "d_velocities")},
    **{f"pbanim.design.stepped_run.ContactTrajectory.{m}": (lambda: {"t": 0.1}) for m in
       ("position", "orientation", "d_position", "d_orientation", "velocities", "d_velocities")},
    **{f"pbanim.design.stepped.ContactScene.{m}": (lambda: {"names": ["v0", "friction"]}) for m in
       ("check_names", "slices", "vector")},
    **{f"pbanim.design.stepped.ContactScene.{m}": (lambda: {"names": ["v0"], "u": np.array([0.5, 0.0, 0.0])})
       for m in ("values", "initial")},
    "pbanim.design.stepped.StaticBox.__init__": lambda: {"half_extents": [0.5, 0.5, 0.1], "center": [0.0, 0.0, 0.5],
                                                         "orientation": [1.0, 0.0, 0.0, 0.0]},
    "pbanim.design.stepped_design.design_contact": lambda: {
        "scene": _contact_scene(), "t_end": 0.2, "names": ["v0"], "h": 0.05, "max_iter": 2,
        "goals": [_contact_goal()]},
    "pbanim.design.stepped_design.down_face": lambda: {
        "tr": simulate_contact(_contact_scene(), 0.2, ["v0"], h=0.05), "t": 0.2},
    "pbanim.design.stepped_sketch.fit_sketch": lambda: {
        "scene": _contact_scene(), "times": [0.1, 0.2, 0.3], "names": ["v0"], "h": 0.05, "max_iter": 2,
        "points": [[0.05, 0.0, 0.1], [0.1, 0.0, 0.1], [0.15, 0.0, 0.1]]},
    "pbanim.design.stepped_sketch.sketch_checks": lambda: {
        "scene": _contact_scene(), "times": [0.1, 0.2, 0.3],
        "points": [[0.05, 0.0, 0.1], [0.1, 0.0, 0.1], [0.15, 0.0, 0.1]]},
    "pbanim.design.stepped_run.simulate_contact": lambda: {"scene": _contact_scene(), "t_end": 0.2, "h": 0.05},
    "pbanim.design.stepped_run.replay_chapter7": lambda: {"scene": _contact_scene(), "t_end": 0.2, "h": 0.05},
}

EXEMPT = {
    "pbanim.design.impact.Impact.__init__": "a record pbanim builds (simulate, apply_impact) and users read",
    "pbanim.design.trajectory.Trajectory.__init__": "a record pbanim builds (simulate) and users read",
    "pbanim.design.rest.Rest.__init__": "a record pbanim builds (simulate) and users read",
    "pbanim.design.stepped_run.ContactTrajectory.__init__": "a record pbanim builds (simulate_contact) and users read",
    "pbanim.design.stepped_run.Switch.__init__": "a record pbanim builds (simulate_contact) and users read",
    "pbanim.design.stepped_design.ContactDesign.__init__": "a record pbanim builds (design_contact) and users read",
    "pbanim.design.stepped_sketch.SketchFit.__init__": "a record pbanim builds (fit_sketch) and users read",
    "pbanim.design.sequences.SequenceSearch.__init__": "a record pbanim builds (search_sequences) and users read",
}


# -- the functions of pbanim.design's modules outside the package's __all__ (control, check, shooting,
# multiple): contracts too, fuzzed by hand with these (they are not on the enumerated surface)
def _goal():
    from pbanim.design.control import position_goal

    return [position_goal(0, 0.6, [0.3, 0.0, 0.5])]


_SKETCH = [(0.1 * k, np.array([0.05 * k, 0.0, 1.1 - 5.0 * (0.1 * k) ** 2])) for k in range(1, 5)]

CALLS.update({
    "pbanim.design.control.goal_system": lambda: {"scene": _scene(), "goals": _goal(), "t_end": 0.6, "h": 0.1},
    "pbanim.design.control.edit": lambda: {"scene": _scene(), "goals": _goal(), "t_end": 0.6, "h": 0.1,
                                           "max_iter": 3},
    "pbanim.design.control.drag": lambda: {"scene": _scene(), "time": 0.6, "t_end": 0.6, "h": 0.1, "frames": 2},
    "pbanim.design.check.output_vector": lambda: {"outputs": [(0, 0.5, "position"), (0, 0.5, "orientation")]},
    "pbanim.design.check.analytic_jacobian": lambda: {"outputs": [(0, 0.5, "position")]},
    "pbanim.design.check.fd_jacobian": lambda: {"scene": _scene(), "t_end": 0.6, "h": 0.1,
                                                "outputs": [(0, 0.6, "position")]},
    "pbanim.design.check.fd_differences": lambda: {"scene": _scene(), "t_end": 0.6, "h": 0.1, "deltas": [1e-4],
                                                   "outputs": [(0, 0.6, "position")]},
    "pbanim.design.shooting.sketch_objective": lambda: {"points": _SKETCH, "tr_pos": lambda t: np.zeros(3)},
    "pbanim.design.shooting.single_shooting": lambda: {"scene": _scene(), "goals": _goal(), "t_end": 0.6, "h": 0.1,
                                                       "maxiter": 5, "sketch": _SKETCH},
    "pbanim.design.multiple.nodes_from_sketch": lambda: {"sketch": _SKETCH, "t_end": 0.6},
    "pbanim.design.multiple.states_from_sketch": lambda: {"sketch": _SKETCH, "node_times": [0.0, 0.2]},
    "pbanim.design.multiple.refine_states": lambda: {"sketch": _SKETCH, "node_times": [0.0], "t_end": 0.6,
                                                     "states": [(np.array([0.0, 0.0, 1.1]), np.zeros(3))],
                                                     "max_nfev": 3},
    "pbanim.design.multiple.multiple_shooting": lambda: {"scene": _scene(), "goals": _goal(), "t_end": 0.6, "h": 0.1,
                                                         "nodes": 2, "maxiter": 5, "max_slides": 1},
})


# -- issue 30 points 3 and 5: the sequence search on a ball thrown at a wall, and the sketch editor
def _wall_scene():
    """A ball thrown at a wall (x ≤ 0.5) in zero gravity: one impact at t = 0.4."""
    return DesignScene([DesignBody(Sphere(0.1), velocity=[1.0, 0.0, 0.0])], [Plane([-1.0, 0.0, 0.0], offset=-0.5)],
                       gravity=[0.0, 0.0, 0.0], restitution=1.0)


_WALL_SKETCH = [(0.2 * k, np.array([0.2 * k if k <= 2 else 0.8 - 0.2 * k, 0.0, 0.0])) for k in range(1, 5)]


def _wall_goal():
    from pbanim.design.control import position_goal

    return [position_goal(0, 0.8, [0.0, 0.0, 0.0])]


def _editor():
    import matplotlib

    matplotlib.use("Agg", force=True)
    from pbanim.design.sketch_ui import SketchEditor

    from matplotlib.figure import Figure

    return SketchEditor(_scene(), 0.6, h=0.1, ax=Figure().subplots())


def _event():
    from matplotlib.backend_bases import MouseEvent

    ed = _editor()
    return MouseEvent("motion_notify_event", ed.canvas, 10.0, 10.0)


CALLS.update({
    "pbanim.design.sequences.Sequence.__init__": lambda: {"planes": [0], "times": np.array([0.4]), "origin": "given"},
    "pbanim.design.sequences.search_sequences": lambda: {"scene": _wall_scene(), "goals": _wall_goal(), "t_end": 0.8,
                                                        "sketch": _WALL_SKETCH, "max_proposals": 2, "maxiter": 20},
    "pbanim.design.sketch_ui.SketchEditor.__init__": lambda: {"scene": _scene(), "t_end": 0.6, "h": 0.1,
                                                              "maxiter": 3, "ax": None},
    **{f"pbanim.design.sketch_ui.SketchEditor.{m}": (lambda: {"event": _event()}) for m in
       ("press", "motion", "release")},
})


def _two_balls():
    """Two balls head on in zero gravity (x = ∓0.5 at ±1 m/s, r = 0.1, ε = 1): one collision at t = 0.4."""
    return DesignScene([DesignBody(Sphere(0.1), position=[-0.5, 0.0, 0.0], velocity=[1.0, 0.0, 0.0]),
                        DesignBody(Sphere(0.1), position=[0.5, 0.0, 0.0], velocity=[-1.0, 0.0, 0.0])],
                       [], gravity=[0.0, 0.0, 0.0], restitution=1.0)


_TWO_SKETCHES = [[(0.2 * k, np.array([s * (-0.1 - abs(0.2 * k - 0.4)), 0.0, 0.0])) for k in range(1, 5)]
                 for s in (1.0, -1.0)]


def _two_goals():
    from pbanim.design.control import position_goal

    return [position_goal(0, 0.8, [-0.5, 0.0, 0.0]), position_goal(1, 0.8, [0.5, 0.0, 0.0])]


def _body_sequence():
    from pbanim.design.body_sequences import BodySequence

    return BodySequence(((0, "body", 1),), np.array([0.4]), "given")


CALLS.update({
    "pbanim.design.body_sequences.BodySequence.__init__": lambda: {"events": [(0, "body", 1)], "times": np.array([0.4]),
                                                                  "origin": "given"},
    "pbanim.design.body_sequences.propose_body_sequences": lambda: {"scene": _two_balls(), "sketches": _TWO_SKETCHES},
    "pbanim.design.body_sequences.solve_body_sequence": lambda: {"scene": _two_balls(), "goals": _two_goals(),
                                                                 "t_end": 0.8, "sketches": _TWO_SKETCHES,
                                                                 "sequence": _body_sequence(), "maxiter": 20},
    "pbanim.design.body_sequences.search_body_sequences": lambda: {"scene": _two_balls(), "goals": _two_goals(),
                                                                   "t_end": 0.8, "sketches": _TWO_SKETCHES,
                                                                   "max_proposals": 2, "maxiter": 20},
})


def _sequence():
    from pbanim.design.sequences import Sequence

    return Sequence((0,), np.array([0.4]), "given")


def _register():
    from pbanim.design.body_sequences import BodySequence
    from pbanim.design.sequences import Sequence
    from pbanim.design.sketch_ui import SketchEditor

    INSTANCES.update({Sequence: _sequence, SketchEditor: _editor, BodySequence: _body_sequence})


_register()
