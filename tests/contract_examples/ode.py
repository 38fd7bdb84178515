"""Valid calls for pbanim.ode (chapter 02): the oscillator ẍ = −x as the right-hand side."""

import numpy as np

from pbanim.ode import SecondOrderJacobian, euler_step


def oscillator(t, y):
    """f(t, [x, v]) = [v, −x], for one state (2,) or a batch (K, 2)."""
    y = np.asarray(y)
    return np.stack([y[..., 1], -y[..., 0]], axis=-1)


def oscillator_jac(t, y):
    return np.array([[0.0, 1.0], [-1.0, 0.0]])


def _step_call():
    return {"fun": oscillator, "y": np.array([1.0, 0.0]), "h": 0.1}


_STEPS = ["pbanim.ode.methods.euler_step", "pbanim.ode.methods.midpoint_step", "pbanim.ode.methods.rk4_step",
          "pbanim.ode.methods.symplectic_euler_step", "pbanim.ode.methods.verlet_step",
          "pbanim.ode.implicit.implicit_euler_step", "pbanim.ode.implicit.implicit_midpoint_step",
          "pbanim.ode.implicit.exponential_euler_step", "pbanim.ode.adaptive.dopri5_step",
          "pbanim.ode.methods.dop853_step", "pbanim.ode.methods.vern7_step", "pbanim.ode.rosenbrock.rodas4_step",
          "pbanim.ode.radau.radau5_step"]

CALLS = {name: _step_call for name in _STEPS}
CALLS.update({
    "pbanim.ode.solve.solve": lambda: {"fun": oscillator, "t_span": [0.0, 1.0], "y0": np.array([1.0, 0.0]),
                                       "h": 0.1, "jac": oscillator_jac},
    "pbanim.ode.methods.Method.__init__": lambda: {"name": "my_euler", "order": 1, "step": euler_step},
    "pbanim.ode.methods.explicit_rk_step": lambda: {"tableau": "rk4", "fun": oscillator,
                                                    "y": np.array([1.0, 0.0]), "h": 0.1},
    "pbanim.ode.implicit.newton_solve": lambda: {"fun": oscillator, "y0": np.array([1.0, 0.0]), "theta_h": 0.1},
    "pbanim.ode.implicit_run.NewtonSteps.__init__": lambda: {"fun": oscillator, "method": "implicit_midpoint"},
})



def _second_order_jacobian():
    return SecondOrderJacobian(np.array([[-4.0, 1.0], [1.0, -4.0]]), -0.1 * np.eye(2))


INSTANCES = {SecondOrderJacobian: _second_order_jacobian}
