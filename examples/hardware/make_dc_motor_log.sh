#!/usr/bin/env bash
# Writes the DC-motor example of docs/hardware.md: tetraspine3_dc.yaml (Tetraspine3 with every
# cable wound by a DC motor: 1 cm spool, 0.3 N m stall torque, 7 rad/s no-load speed) and
# dc_motor_log.csv, a log of "hardware" whose motors are stronger and faster (0.4 N m,
# 10 rad/s) under the strong sine excitation, read through a noisy, quantising load cell.
# Run from the repository root.
set -euo pipefail
here=examples/hardware
python3 - "$here/tetraspine3_dc.yaml" <<'PY'
import dataclasses, sys
from tensim.models import tetraspine3
from tensim.structure import DCMotor, save_structure
motor = DCMotor(spool_radius=0.01, stall_torque=0.3, no_load_speed=7.0, rotor_inertia=2e-4,
                coulomb_friction=0.02)
robot = tetraspine3()
save_structure(dataclasses.replace(robot, cables=tuple(
    dataclasses.replace(c, motor=dataclasses.replace(c.motor, dc=motor))
    for c in robot.cables)), sys.argv[1])
PY
tensim --quiet make-log --model "$here/tetraspine3_dc.yaml" \
    --controller examples/hardware/sine_excitation.yaml --duration 5 \
    --set stall_torque=0.4,no_load_speed=10 --noise 0.1 --quantise --seed 4 \
    --out "$here/dc_motor_log.csv"
