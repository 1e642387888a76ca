#!/usr/bin/env bash
# Writes the example disturbance logs of docs/hardware.md: disturbance_log.csv (the paper's
# Fig. 3 push, shortened, on stiffer and rougher "hardware" with a noisy, delayed load cell)
# and disturbance_log_no_loads.csv (the same log without its load columns and experiment
# header, as a logger that forgot the push would write it). Run from the repository root.
set -euo pipefail
here=examples/hardware
tensim --quiet make-log --controller tetraspine3_impedance --duration 7 \
    --experiment disturbance --experiment-params start=2.5,rise=1,hold=1.5,fall=1 \
    --set friction=0.1,stiffness=252.076 --offset 0.5 --noise 0.1 --delay 0.025 --quantise \
    --seed 3 --out "$here/disturbance_log.csv"
python3 - "$here/disturbance_log.csv" "$here/disturbance_log_no_loads.csv" <<'PY'
import csv, sys
with open(sys.argv[1], newline="") as f:
    rows = list(csv.reader(f))
head = next(i for i, r in enumerate(rows) if r and r[0] == "time_s")
keep = [k for k, name in enumerate(rows[head]) if not name.startswith("load_N/")]
with open(sys.argv[2], "w", newline="") as f:
    out = csv.writer(f, lineterminator="\n")
    for i, r in enumerate(rows):
        if i < head:
            if not r[0].startswith("# experiment"):
                out.writerow(r)
        elif i == head or any(r[k] for k in keep[1:]):
            out.writerow([r[k] for k in keep])
PY
echo "wrote $here/disturbance_log.csv and $here/disturbance_log_no_loads.csv"
