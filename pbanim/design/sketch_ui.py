"""A sketching interface for motion design (chapter 10, issue 30 point 5; part of :mod:`pbanim.design`).

:class:`SketchEditor` draws the motion S(t, u) of body 0 in a matplotlib axes (a window, or a notebook
cell with an interactive backend) projected on two world axes, and listens to the mouse:

* **drag** (``mode = "drag"``): press near a point of the trajectory (within ``pick_radius`` pixels) to
  grab the body at that time t*; every motion event is one Gauss–Newton (continuation) update of u from
  the previous solution,

      δu = M⁻¹Aᵀ(AM⁻¹Aᵀ + λ²𝟙)⁻¹ (x̄ − x(t*; u)),   A = ∂x(t*)/∂u,   u ← u + δu

  (:func:`pbanim.design.control.min_norm_update`, the deck's min-norm edit; x̄ the pointer, the third
  coordinate kept), and the new S(t, u) with its ∂S/∂u is simulated at once: that one simulation both
  redraws the motion and gives the A and x(t*) of the next event. Holding the pointer still repeats the
  update: Newton's iteration on the goal. ``predict=True`` instead draws the first-order prediction
  x(t) + (∂x(t)/∂u)(u − u_lin) between linearizations made at press and release (no simulation per
  event; the prediction's error at release is reported in ``prediction_error``);
* **sketch** (``mode = "sketch"``): press, move and release draw a stroke; its points are spaced evenly
  in time over [0, t_end] (the stroke is drawn at the pace of the motion) and become the sketch of a
  boundary value problem solved on release: multiple shooting (:mod:`pbanim.design.multiple`), or the
  search over impact sequences (:mod:`pbanim.design.sequences`, ``solver="sequences"``), with the stroke's
  last point as the position goal at t_end.

**At the pace of the mouse** (≥ 30 exact updates a second, ``pbanim bench design``): S and ∂x(t*)/∂u come
from the scene's lean twin — a ball's parabolas and the chain rule through its impacts
(:mod:`pbanim.design.lean_ball`), a box's rotation alone stepped with its tangent rows on a flight grid
``h_flight`` (:mod:`pbanim.design.lean_box`; the drawing between grid points is the parabola from the last
impact) — each equal to :func:`pbanim.design.simulate` (ORACLES L7); where a twin does not apply or
declines (a rest, a graze, a touch), and with ``lean=False``, the readable S runs (``path`` says which).
The redraw blits: the axes without the motion are cached once per view and only the three artists are drawn
over them (``blit=False``, or a canvas that cannot blit: a full redraw).

Everything the editor does goes through its handlers (``press``, ``motion``, ``release``), which take
matplotlib :class:`~matplotlib.backend_bases.MouseEvent` objects: a test synthesizes the events on the
Agg backend and checks the state after each (``u``, ``grab``, ``residual``, ``updates``, ``stroke``).

==========  ==================  ===========================================================
symbol      code                meaning
==========  ==================  ===========================================================
u           ``u``, ``names``    the parameters being edited (default x₀, v₀ of body 0)
t*          ``grab``            the grabbed time (None when nothing is held)
x̄           ``target``          the pointer in world coordinates (m)
λ           ``damping``         damped least squares (keeps an update bounded near a graze)
==========  ==================  ===========================================================

Limiting cases: a pointer on the trajectory gives δu = 0; with as many independent goal rows as
parameters the update is Newton's step.

References: J. Popović, S. M. Seitz, M. Erdmann, Z. Popović, A. Witkin, "Interactive manipulation of
rigid body simulations", SIGGRAPH 2000 (§5, the interactive loop); Popović, Seitz & Erdmann, ACM TOG 2003
(sketching); J. D. Hunter, matplotlib event handling (``mpl_connect``).
"""

from __future__ import annotations

import numpy as np

from ..contracts import Array, Choice, Flag, Has, Int, Obj, Opt, Real, Seq, contract
from ..errors import InvalidInput
from .control import min_norm_update, position_goal
from .scene import DesignScene
from .specs import ParameterNames

__all__ = ["SketchEditor"]

MODES = ("drag", "sketch")
_EVENT = Has("x", "y", "xdata", "ydata", "inaxes", what="a matplotlib MouseEvent")
_AXES = Opt(Has("figure", "plot", "transData", what="a matplotlib Axes"))
SOLVERS = ("multiple", "sequences")


class SketchEditor:
    """An interactive editor of S(t, u) (module docstring). ``ax``: the matplotlib axes to draw in (default
    a new pyplot figure); ``view``: the two world axes shown (default x, z); ``h``: the simulation's grid
    step, which is also the spacing of the drawn points; ``h_flight``: the lean box's flight step (default h);
    ``lean``, ``blit``: the fast paths of the module docstring (on by default)."""

    @contract(scene=Obj(DesignScene), t_end=Real(gt=0), names=Opt(ParameterNames("scene")), u=Opt(Array((None,))),
              h=Real(gt=0), view=Seq(Int(ge=0, le=2), min_len=2, max_len=2), pick_radius=Real(gt=0),
              predict=Flag(), damping=Real(ge=0), mode=Choice(MODES), solver=Choice(SOLVERS),
              maxiter=Int(ge=1, le=10_000), ax=_AXES, lean=Flag(), blit=Flag(), h_flight=Opt(Real(gt=0)))
    def __init__(self, scene, t_end, *, names=None, u=None, h: float = 0.02, view=(0, 2), pick_radius: float = 12.0,
                 predict: bool = False, damping: float = 1e-3, ax=None, mode: str = "drag", solver: str = "multiple",
                 maxiter: int = 100, lean: bool = True, blit: bool = True,
                 h_flight=None) -> None:
        if scene.N != 1:
            raise InvalidInput(f"SketchEditor edits one body's motion; the scene has {scene.N} bodies")
        if view[0] == view[1]:
            raise InvalidInput(f"view must name two different world axes, got {view}")
        self.scene, self.t_end, self.h = scene, float(t_end), float(h)
        self.names = scene.check_names(["x0", "v0"] if names is None else names)
        self.u = np.asarray(scene.vector(self.names) if u is None else u, dtype=float).reshape(-1).copy()
        scene.values(self.names, self.u)
        self.view, self.pick_radius, self.predict = [int(v) for v in view], float(pick_radius), bool(predict)
        self.damping, self.mode, self.solver, self.maxiter = float(damping), mode, solver, int(maxiter)
        self.grab, self.target, self.residual, self.updates = None, None, 0.0, 0
        self.stroke, self.result, self.prediction_error = [], None, 0.0      # 0 until a drag / a release says
        self.lean, self.blit, self.path, self.n_impacts, self._bg = bool(lean), bool(blit), "", 0, None
        self.h_flight = self.h if h_flight is None else float(h_flight)
        if ax is None:
            import matplotlib.pyplot as plt
            ax = plt.subplots(figsize=(7, 4))[1]
        self.ax, self.canvas = ax, ax.figure.canvas
        self.line, = ax.plot([], [], "-", color="C0", lw=1.5)
        self.marker, = ax.plot([], [], "o", color="C3", ms=8)
        self.ink, = ax.plot([], [], "-", color="0.4", lw=1)
        for p in scene.planes:
            self._draw_plane(p)
        ax.set_xlabel("xyz"[self.view[0]] + " (m)"), ax.set_ylabel("xyz"[self.view[1]] + " (m)")
        self._ids = [self.canvas.mpl_connect(k, f) for k, f in (("button_press_event", self.press),
                                                                ("motion_notify_event", self.motion),
                                                                ("button_release_event", self.release),
                                                                ("draw_event", self._forget_background))]
        self._simulate(None)
        self._redraw(full=True)
        ax.relim(), ax.autoscale_view()

    # ----------------------------------------------------------------- the model
    def _simulate(self, t_star):
        """S at the drawn times and x(t*), ∂x(t*)/∂u at u (one run). ``lean``: the lean twin of the scene
        (:mod:`pbanim.design.lean_ball`, :mod:`pbanim.design.lean_box`) at the drawn times, spaced h; where it
        does not apply or declines (a graze, a rest, a touch), and with ``lean=False``, the readable
        :func:`pbanim.design.simulate` on its grid of step h. ``path`` says which ran."""
        from .simulate import simulate

        if self.lean:
            out = self._lean_run(t_star)
            if out is not None:
                self.t, self.X, x_star, A, self.n_impacts = out
                if t_star is not None:
                    self.x_star, self.A = x_star, A
                self.path = "lean"
                return
        tr = simulate(self.scene, self.t_end, self.names, self.u, times=[] if t_star is None else [t_star], h=self.h,
                      warn=False, sensitivities=t_star is not None)
        self.t, self.X, self.path, self.n_impacts = tr.t.copy(), tr.positions(0).copy(), "readable", len(tr.impacts)
        if t_star is not None:
            self.x_star, self.A = tr.position(0, t_star), tr.d_position(0, t_star)

    def _lean_run(self, t_star):
        from .lean_ball import _ball_run, ball_applies
        from .lean_box import _box_run, box_applies

        t = np.linspace(0.0, self.t_end, int(round(self.t_end / self.h)) + 1)
        if ball_applies(self.scene, self.names):
            out = _ball_run(self.scene, self.names, self.u, self.t_end, t, t_star)
        elif box_applies(self.scene, self.names):
            out = _box_run(self.scene, self.names, self.u, self.t_end, t, t_star, self.h_flight)
        else:
            return None
        return None if out is None else (t,) + tuple(out[:3]) + (len(out[3]),)

    def _linearize(self):
        """x(t) and ∂x(t)/∂u at every drawn time (the prediction's model, made at press and release)."""
        from .simulate import simulate

        self._simulate(None)
        grid = [float(t) for t in self.t[1:]]
        tr = simulate(self.scene, self.t_end, self.names, self.u, times=grid, h=self.h, warn=False)
        self.lin_u = self.u.copy()
        self.lin_X = np.array([self.X[0]] + [tr.position(0, t) for t in grid])
        D0 = np.zeros((3, self.u.size))                      # x(0) = x₀: ∂x(0)/∂u is 𝟙 on the x₀ block
        sl = self.scene.slices(self.names)
        if "x0" in sl:
            D0[:, sl["x0"]] = np.eye(3)
        self.lin_D = np.array([D0] + [tr.d_position(0, t) for t in grid])

    def _redraw(self, full: bool = False):
        """Set the artists' data and show them: by blitting where the canvas can (the axes without the motion
        cached once per view, then only the three artists drawn over it), else a full redraw."""
        self.line.set_data(self.X[:, self.view[0]], self.X[:, self.view[1]])
        if self.grab is not None:
            x = self.X[self.grab_index]
            self.marker.set_data([x[self.view[0]]], [x[self.view[1]]])
        else:
            self.marker.set_data([], [])
        S = np.array(self.stroke).reshape(-1, 2)
        self.ink.set_data(S[:, 0], S[:, 1])
        c, dyn = self.canvas, (self.line, self.marker, self.ink)
        if full or not self.blit or not getattr(c, "supports_blit", False):
            c.draw_idle()
            return
        key = (tuple(self.ax.viewLim.bounds), tuple(self.ax.bbox.bounds))
        if self._bg is None or self._bg_key != key:
            for art in dyn:
                art.set_visible(False)
            self._capturing = True
            try:
                c.draw()
            finally:
                self._capturing = False
                for art in dyn:
                    art.set_visible(True)
            self._bg, self._bg_key = c.copy_from_bbox(self.ax.bbox), key
        c.restore_region(self._bg)
        for art in dyn:
            self.ax.draw_artist(art)
        c.blit(self.ax.bbox)

    def _forget_background(self, event) -> None:
        if not getattr(self, "_capturing", False):
            self._bg = None

    def _draw_plane(self, plane):
        n, o = plane.normal[self.view], plane.offset * plane.normal[self.view]
        if np.linalg.norm(n) < 1e-9:
            return
        d = np.array([-n[1], n[0]]) / np.linalg.norm(n)
        P = o[None] + np.outer([-10.0, 10.0], d)
        self.ax.plot(P[:, 0], P[:, 1], color="k", lw=1, scalex=False, scaley=False)

    def _world(self, event):
        """The pointer in world coordinates: the two viewed axes from the event, the third kept from x(t*)
        (drag) or from x₀ (sketch)."""
        x = (self.X[self.grab_index] if self.grab is not None else self.X[0]).copy()
        x[self.view[0]], x[self.view[1]] = event.xdata, event.ydata
        return x

    # ----------------------------------------------------------------- the handlers
    @contract(event=_EVENT)
    def press(self, event) -> None:
        """Grab the trajectory point nearest the pointer (drag), or start a stroke (sketch)."""
        if event.inaxes is not self.ax or event.xdata is None:
            return
        if self.mode == "sketch":
            self.stroke = [(event.xdata, event.ydata)]
            self._redraw()
            return
        px = self.ax.transData.transform(self.X[:, self.view])
        dist = np.hypot(px[:, 0] - event.x, px[:, 1] - event.y)
        i = int(np.argmin(dist[1:])) + 1                     # the start x₀ is moved by editing x₀, not here
        if dist[i] > self.pick_radius:
            return
        self.grab, self.grab_index = float(self.t[i]), i
        self._simulate(self.grab)
        if self.predict:
            self._linearize()
        self.residual = 0.0
        self._redraw()

    @contract(event=_EVENT)
    def motion(self, event) -> None:
        """One update toward the pointer (drag) or one more stroke point (sketch)."""
        if event.inaxes is not self.ax or event.xdata is None:
            return
        if self.mode == "sketch":
            if self.stroke:
                self.stroke.append((event.xdata, event.ydata))
                self._redraw()
            return
        if self.grab is None:
            return
        self.target = self._world(event)
        self.step()
        self._redraw()

    @contract(event=_EVENT)
    def release(self, event) -> None:
        """Let go (drag; a prediction is replaced by S), or solve the sketched problem (sketch)."""
        if self.mode == "sketch":
            if len(self.stroke) >= 3:
                self.solve_stroke()
            self._redraw()
            return
        if self.grab is not None and self.predict:
            pred = self.X.copy()
            self._simulate(self.grab)
            self.prediction_error = float(np.abs(self.X - pred).max()) if pred.shape == self.X.shape else np.inf
        self.grab = None
        self._redraw()

    # ----------------------------------------------------------------- the updates
    def step(self) -> float:
        """One Gauss–Newton update of u toward ``target`` at the grabbed time; returns the residual
        |x̄ − x(t*)| after it (of S itself, or of the prediction with ``predict=True``)."""
        if self.grab is None or self.target is None:
            raise InvalidInput("SketchEditor.step: nothing is grabbed (press near the trajectory first)")
        if self.predict:
            D = self.lin_D[self.grab_index]
            r = self.target - (self.lin_X[self.grab_index] + D @ (self.u - self.lin_u))
            self.u = self.u + min_norm_update(D, r, damping=self.damping).du
            self.scene.values(self.names, self.u)
            self.X = self.lin_X + self.lin_D @ (self.u - self.lin_u)
            x = self.X[self.grab_index]
        else:
            r = self.target - self.x_star
            self.u = self.u + min_norm_update(self.A, r, damping=self.damping).du
            self.scene.values(self.names, self.u)
            self._simulate(self.grab)
            x = self.x_star
        self.updates += 1
        self.residual = float(np.linalg.norm(self.target - x))
        return self.residual

    def solve_stroke(self):
        """The stroke as a sketch (even times over [0, t_end]), solved by the chosen ``solver``; u becomes
        the solution's (x₀, v₀) (or its full first state for a box) whatever its success, which is in
        ``result``."""
        from .multiple import multiple_shooting
        from .sequences import search_sequences

        S = np.array(self.stroke, dtype=float)
        ts = np.linspace(0.0, self.t_end, len(S))
        pts = []
        for t, (a, b) in zip(ts, S):
            x = self.X[0].copy()
            x[self.view[0]], x[self.view[1]] = a, b
            pts.append((float(t), x))
        goal = [position_goal(0, self.t_end, pts[-1][1])]
        start = self.scene.with_values(self.names, self.u)
        if self.solver == "sequences":
            res = search_sequences(start, goal, self.t_end, pts[1:], maxiter=self.maxiter)
            names = ["x0", "v0"]
        else:
            res = multiple_shooting(start, goal, self.t_end, sketch=pts[1:], maxiter=self.maxiter)
            names = res.names
        self.result = res
        if np.all(np.isfinite(res.u)):
            self.names, self.u = list(names), np.asarray(res.u, dtype=float).copy()
            self.scene = start
            self._simulate(None)
        return res

    def disconnect(self) -> None:
        """Stop listening to the mouse."""
        for i in self._ids:
            self.canvas.mpl_disconnect(i)
