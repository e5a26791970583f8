"""An implicit run that finds its chain indefinite gives back a state from before the trouble,
and the replay continues explicitly from there instead of from t = 0 (docs/decisions.md, "the
replay's time step").

The case: the USB cable (copper axial springs, 2e9 Pa) hangs still between level clips for
0.35 s, then the clips close from 0.42 m to 0.3 m apart in 0.03 s (4 m/s). With the thesis'
absolute damping the implicit step at 1 ms finds the compressed chain indefinite at 0.352 s.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import level_clips, sagging_guess

from dloplan import catalogue_cable
from dloplan.sim import ClipTrajectory, equilibrium, simulate
from dloplan.sim.dynamics import INDEFINITE_BACKOFF, IndefiniteStep
from dloplan.verify.replay import replay

DT = 1e-3
"""The implicit step [s] (the replay's)."""


@pytest.fixture(scope="module")
def pushed():
    """The cable, its planned shapes (at rest before and after) and the clips' knots."""
    cable = catalogue_cable("usb", n_links=8)
    start = equilibrium(cable, sagging_guess(cable, 0.42), level_clips(0.42))
    end = equilibrium(cable, sagging_guess(cable, 0.3, -0.1), level_clips(0.3))
    assert start.converged and end.converged
    times = np.array([0.0, 0.35, 0.38])
    return cable, np.stack([start.shape, start.shape, end.shape]), times, [start.clips,
                                                                          start.clips, end.clips]


def test_an_indefinite_implicit_run_gives_back_its_state_from_before_the_failure(pushed):
    """The state given back lies between one and two :data:`INDEFINITE_BACKOFF` before the
    step that failed (the states kept every 0.1 s), and it is the run's own: the same records,
    shape and velocity as the implicit run stopped there (bit for bit: the same steps)."""
    cable, shapes, times, poses = pushed
    clips = ClipTrajectory(times, poses)
    options = dict(dt=DT, scheme="implicit", record_interval=DT, damping="absolute")
    with pytest.raises(IndefiniteStep, match="not positive enough") as caught:
        simulate(cable, shapes[0], clips, duration=1.0, **options)
    failed, partial = caught.value.time, caught.value.partial
    assert failed == pytest.approx(0.352)
    given = float(partial.times[-1])
    assert failed - 2 * INDEFINITE_BACKOFF <= given <= failed - INDEFINITE_BACKOFF
    assert partial.steps * DT == pytest.approx(given) and not partial.settled
    same = simulate(cable, shapes[0], clips, duration=given, **options)
    np.testing.assert_array_equal(partial.times, same.times)
    np.testing.assert_array_equal(partial.shapes, same.shapes)
    np.testing.assert_array_equal(partial.velocity, same.velocity)


def test_the_replay_continues_explicitly_from_the_state_given_back(pushed):
    """``replay`` (scheme "auto") steps implicitly, finds the chain indefinite when the clips
    push, and continues explicitly from the state given back (0.2 s) rather than from the
    start: against the explicit replay throughout, the knot deviations agree to 2 um
    (measured 1.1 um: the hanging cable's first 0.2 s differ by the implicit step's first-order
    error), the peak tension to 1 % (measured 0.16 %: 121.4 / 121.3 N, the push's axial ringing,
    stepped explicitly in both) and the final shape to 1 um, with fewer explicit steps."""
    cable, shapes, times, poses = pushed
    options = dict(settle_duration=1.0, tolerance=0.05, damping="absolute")
    fast = replay(cable, shapes, (times, poses), **options)
    reference = replay(cable, shapes, (times, poses), scheme="explicit", **options)
    run = fast.simulation
    implicit = run.times <= 0.2 + 1e-12
    assert np.allclose(np.diff(run.times[implicit]), DT)  # 1 ms records up to the state
    assert run.dt == reference.simulation.dt  # explicit after it, at the thesis' step
    assert run.steps < reference.simulation.steps - 0.2 / run.dt + 300
    np.testing.assert_allclose(fast.deviations, reference.deviations, atol=2e-6)
    assert fast.peak_tension == pytest.approx(reference.peak_tension, rel=0.01)
    assert fast.final_deviation == pytest.approx(reference.final_deviation, abs=1e-6)
    assert (fast.ok, fast.settled) == (reference.ok, reference.settled)
