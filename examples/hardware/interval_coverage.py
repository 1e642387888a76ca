"""How often sysid's 95 % intervals cover the truth: refits on 5 disjoint 3 s windows of
simulated 15 s logs with known parameters (docs/hardware.md quotes what this prints).

    python examples/hardware/interval_coverage.py [SEEDS]

Cases: ``sensor`` (the model is right; fit offset and delay), ``stiffness`` (stiffer
hardware; fit stiffness, offset and delay), ``misspecified`` (stiffer hardware with more
friction; fit offset and delay only, so the residuals keep a model error) and ``stand-in``
(a log of another model than the one fitted: three times the cable damping, which is not
fitted, MuJoCo's elliptic friction cone with a stiffer contact and a 0.5 ms step; fit offset
and delay, whose truth does not depend on the model).
"""

from __future__ import annotations

import sys

import numpy as np

from tensim.control import load_controller, tetraspine_sine
from tensim.hardware import PAPER_LOADCELL, SensorModel, SysidSettings, identify, simulated_log
from tensim.model import WorldOptions
from tensim.models import tetraspine3

OTHER_WORLD = WorldOptions(timestep=0.0005, cone="elliptic", contact_timeconst=0.01)
CASES = {  # name -> (hardware parameters, its world, fitted names, their true values)
    "sensor": ({}, None, ["offset", "delay"], [0.5, 0.03]),
    "stiffness": ({"stiffness": 252.076}, None, ["stiffness", "offset", "delay"],
                  [252.076, 0.5, 0.03]),
    "misspecified": ({"stiffness": 252.076, "friction": 0.1}, None, ["offset", "delay"],
                     [0.5, 0.03]),
    "stand-in": ({"stiffness": 252.076, "damping": 60.0}, OTHER_WORLD, ["offset", "delay"],
                 [0.5, 0.03]),
}


def coverage(case: str, seeds: int) -> None:
    robot = tetraspine3()
    impedance = load_controller("tetraspine3_impedance", robot)
    gait = impedance.with_gait(tetraspine_sine(robot, 0.05, 1.0))
    sensor = SensorModel(offset=0.5, noise=0.1, delay=0.03, loadcell=PAPER_LOADCELL)
    hardware, world, names, truth = CASES[case]
    covered, naive, ratio, pairs = np.zeros(len(names)), np.zeros(len(names)), [], []
    for seed in range(seeds):
        log = simulated_log(robot, gait, 15.0, parameters=hardware, sensor=sensor,
                            rng=np.random.default_rng(seed), feedback_period=0.1, world=world)
        fits, errors = [], []
        for k in range(5):
            result = identify([log], robot, impedance, names, settings=SysidSettings(
                max_simulations=30, fit_window=(3.0 * k, 3.0 * k + 2.99)))
            ci = np.array([p["ci95"] for p in result.parameters().values()])
            covered += np.abs(result.fitted - truth) <= ci
            naive += np.abs(result.fitted - truth) <= 1.96 * result.naive_stderr
            fits.append(result.fitted)
            errors.append(result.stderr)
        fits, errors = np.array(fits), np.array(errors)
        ratio.append(np.std(fits, axis=0, ddof=1) / np.median(errors, axis=0))
        pairs += [np.max(np.abs(fits[a] - fits[b]) / np.hypot(errors[a], errors[b]))
                  for a in range(5) for b in range(a)]
    n = 5 * seeds
    cover = ", ".join(f"{name} {int(c)}/{n}" for name, c in zip(names, covered, strict=True))
    plain = ", ".join(f"{int(c)}/{n}" for c in naive)
    spread = ", ".join(f"{r:.2f}" for r in np.mean(ratio, axis=0))
    print(f"{case}: the 95 % intervals cover the truth in {cover} refits (independent-sample "
          f"intervals: {plain}); scatter of the refits / median standard error: {spread}; "
          f"largest difference of two refits: {max(pairs):.2f} combined standard errors")


if __name__ == "__main__":
    for name in CASES:
        coverage(name, int(sys.argv[1]) if len(sys.argv) > 1 else 2)
