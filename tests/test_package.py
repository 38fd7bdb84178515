"""Package-level contracts: lazy heavy imports, the CLI, the scene pipeline, the error types."""

import subprocess
import sys

import numpy as np
import pytest

import pbanim
from pbanim.errors import SimulationDiverged
from pbanim.particles import Gravity, ParticleSystem
from pbanim.scene import Effect, Scene

HEAVY = ("sympy", "qpsolvers", "proxsuite", "matplotlib")


def test_import_pbanim_loads_no_heavy_dependency():
    # the DESIGN contract: `import pbanim` loads numpy and scipy only
    code = "import sys, pbanim; print(','.join(m for m in %r if m in sys.modules))" % (HEAVY,)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"import pbanim loaded: {out.stdout.strip()}"


def test_cli_lists_figures_and_benchmarks():
    from pbanim.bench import available

    out = subprocess.run([sys.executable, "-m", "pbanim.cli", "list", "bench"], capture_output=True, text=True,
                         check=True)
    rows = [line.split(maxsplit=2) for line in out.stdout.splitlines() if line.strip()]
    assert [r[:2] for r in rows] == [["bench", name] for name in available()]
    assert all(len(r) == 3 and r[2].strip() for r in rows), "every benchmark has its one-line description"


def test_cli_rejects_unknown_benchmark():
    out = subprocess.run([sys.executable, "-m", "pbanim.cli", "bench", "nope"], capture_output=True, text=True)
    assert out.returncode == 2 and "run_bench: name must be one of" in out.stderr and "got 'nope'" in out.stderr


class Spy(Effect):
    """An effect that counts its calls, to prove undeclared stages never run."""

    name = "spy"
    phase = "force"
    calls = 0

    def apply(self, t, y, Q):
        Spy.calls += 1


def test_pipeline_runs_only_declared_stages():
    ps = ParticleSystem([[0.0, 1.0]], masses=1.0)
    Spy.calls = 0
    Scene(ps, [Gravity()]).simulate(0.1, 0.01)
    assert Spy.calls == 0  # declared nowhere, never called
    scene = Scene(ps, [Gravity(), Spy()])
    assert scene.pipeline == ("gravity", "spy", "integrate")
    scene.simulate(0.1, 0.01, method="rk4")
    assert Spy.calls == 4 * 10  # rk4: four force evaluations per step, ten steps


def test_free_fall_energy_and_divergence_error():
    # free fall under gravity: RK4 is exact on a quadratic trajectory (ORACLES A8)
    ps = ParticleSystem([[0.0, 10.0]], [[1.0, 0.0]], masses=2.0)
    res = Scene(ps, [Gravity()]).simulate(1.0, 0.1, method="rk4")
    x, y = res.y[0, -1], res.y[1, -1]
    assert abs(x - 1.0) < 1e-14 and abs(y - (10 - 0.5 * 9.81)) < 1e-13
    E = res.diagnostics["energy"]
    assert np.max(np.abs(E - E[0])) < 1e-12 * abs(E[0])

    class Blowup(Effect):
        name, phase = "blowup", "force"

        def apply(self, t, y, Q):
            Q[:] = np.nan  # what an exploding force produces

    with pytest.raises(SimulationDiverged, match="not finite"):
        Scene(ps, [Blowup()]).simulate(1.0, 0.1, method="euler")


def test_scene_rejects_bad_step():
    ps = ParticleSystem([[0.0, 1.0]])
    with pytest.raises(ValueError, match="h must be a finite number > 0, got -0.1"):
        Scene(ps, [Gravity()]).simulate(1.0, -0.1)


def test_mass_must_be_positive():
    with pytest.raises(ValueError, match=r"masses must be a float array .*entries > 0.* got -1.0"):
        ParticleSystem([[0.0, 0.0]], masses=-1.0)


def test_version():
    assert pbanim.__version__
