"""Sysid's 95 % intervals against the logging rate and sensor noise (docs/hardware.md quotes
what this prints).

    python examples/hardware/noise_intervals.py [DRAWS]

``rate``: one motion of the stand-in (a log of another model than the one fitted: three times
the cable damping, MuJoCo's elliptic friction cone with a stiffer contact and a 0.5 ms step,
read through 0.1 N of noise) logged every 200, 50 and 10 ms; each interval over the 200 ms
log's. ``one point``: the 8 s impedance log (stiffer cables and less friction than nominal,
a 0.5 N offset and a 30 ms delay, logged every 10 ms) through 0.2 N of sensor noise, judged
at the truth, over the clean log judged there, per noise draw. ``fitted``: the same logs
fitted (the fit point moves with the draw). ``rough``: the clean log's residual at the truth
with the stiffness or the friction moved a hair (the plateau the fits stop on). ``white``: the
intervals at the truth through 2 N of noise (nearly white residuals) over the
independent-sample ones, mean of four draws.
"""

from __future__ import annotations

import sys

import numpy as np

from tensim.control import load_controller, tetraspine_sine
from tensim.hardware import SensorModel, SysidSettings, errors_at, identify, simulated_log
from tensim.model import WorldOptions
from tensim.models import tetraspine3

TRUTH = {"stiffness": 252.076, "friction": 0.1, "offset": 0.5, "delay": 0.03}
SETTINGS = SysidSettings(fit_window=(0.0, 5.0), validate_window=(5.0, 8.0))


def _figures(values: np.ndarray) -> str:
    return ", ".join(f"{v:.2f}" for v in values)


def rates(robot, impedance) -> None:
    gait = impedance.with_gait(tetraspine_sine(robot, 0.05, 1.0))
    world = WorldOptions(timestep=0.0005, cone="elliptic", contact_timeconst=0.01)
    intervals = {}
    for period in (0.2, 0.05, 0.01):
        log = simulated_log(robot, gait, 7.0, parameters={"stiffness": 252.076,
                                                           "damping": 60.0},
                            sensor=SensorModel(offset=0.5, noise=0.1, delay=0.025),
                            rng=np.random.default_rng(1), world=world, feedback_period=period)
        result = identify([log], robot, impedance, ["stiffness", "offset", "delay"],
                          settings=SysidSettings(fit_window=(1.0, 6.99), max_simulations=12))
        intervals[period] = np.array([p["ci95"] for p in result.parameters().values()])
    for period in (0.05, 0.01):
        print(f"rate: stiffness, offset, delay intervals logged every {period * 1000:g} ms / "
              f"every 200 ms: {_figures(intervals[period] / intervals[0.2])}")


def impedance_log(robot, impedance, noise: float, seed: int):
    return simulated_log(robot, impedance, 8.0, parameters={"stiffness": 252.076,
                                                           "friction": 0.1},
                         sensor=SensorModel(offset=0.5, noise=noise, delay=0.03),
                         rng=np.random.default_rng(seed), feedback_period=0.01)


def noise(robot, impedance, draws: int) -> None:
    logs = [impedance_log(robot, impedance, 0.0 if k == 0 else 0.2, k or 1)
            for k in range(draws + 1)]
    at_truth = [errors_at([log], robot, impedance, TRUTH, settings=SETTINGS) for log in logs]
    fits = [identify([log], robot, impedance, list(TRUTH), settings=SETTINGS) for log in logs]
    intervals = [np.array([p["ci95"] for p in fit.parameters().values()]) for fit in fits]
    truth = np.array(list(TRUTH.values()))
    for draw, (fit, (errors, _, rms)) in enumerate(zip(fits, at_truth, strict=True)):
        miss = np.abs(fit.fitted - truth)
        print(f"{'clean log' if draw == 0 else f'noise draw {draw}'}: the fit misses the "
              f"stiffness by {miss[0]:.1f} N/m and the delay by {miss[3] * 1000:.2f} ms; "
              f"residual {np.sqrt(np.mean(fit.optimizer.fun**2)):.3f} N RMS (at the truth "
              f"{rms:.3f} N)")
        if draw:
            point = np.array(list(errors.values())) / np.array(list(at_truth[0][0].values()))
            print(f"  {', '.join(TRUTH)} intervals with 0.2 N / clean: one point "
                  f"{_figures(point)}; fitted {_figures(intervals[draw] / intervals[0])}")


def rough(robot, impedance) -> None:
    """The clean log's residual around the truth: contacts make it change irregularly under
    tiny parameter changes, so the truth's own residual is one value of a rough plateau."""
    log = impedance_log(robot, impedance, 0.0, 1)
    values = []
    for name, step in (("stiffness", -0.1), ("stiffness", 0.1), ("friction", -1e-4),
                       ("friction", 1e-4)):
        moved = {**TRUTH, name: TRUTH[name] + step}
        values.append(errors_at([log], robot, impedance, moved, settings=SETTINGS)[2])
    print(f"rough: clean residual at the truth with the stiffness -/+0.1 N/m, the friction "
          f"-/+1e-4: {', '.join(f'{v:.3f}' for v in values)} N RMS")


def white(robot, impedance) -> None:
    """The estimate where sensor noise makes nearly all the residual: 2 N of it, 40 times the
    replay's own error, judged at the truth."""
    ratios = []
    for seed in range(1, 5):
        _, errors, _ = errors_at([impedance_log(robot, impedance, 2.0, seed)], robot,
                                 impedance, TRUTH, settings=SETTINGS)
        ratios.append(errors.stderr / errors.naive)
    print(f"white: {', '.join(TRUTH)} intervals through 2 N of noise / independent-sample: "
          f"{_figures(np.mean(ratios, axis=0))}")


def main() -> None:
    draws = int(sys.argv[1]) if len(sys.argv) > 1 else 4
    robot = tetraspine3()
    impedance = load_controller("tetraspine3_impedance", robot)
    rates(robot, impedance)
    noise(robot, impedance, draws)
    rough(robot, impedance)
    white(robot, impedance)


if __name__ == "__main__":
    main()
