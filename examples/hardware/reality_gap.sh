#!/usr/bin/env bash
# The commands of docs/hardware.md ("Logs that say what happened"), run as written; their
# printed output is what the docs show. Run from the repository root:
#   bash examples/hardware/reality_gap.sh
set -euo pipefail
run() { echo "\$ $*"; "$@" 2>&1; echo; }
out=${OUT:-runs/reality_gap}
mkdir -p "$out"
run tensim --quiet compare examples/hardware/sine_log.csv --out "$out/compare_sine"
run tensim --quiet make-log --controller tetraspine3_impedance --duration 7 \
    --experiment disturbance --experiment-params start=2.5,rise=1,hold=1.5,fall=1 \
    --set friction=0.1,stiffness=252.076 --offset 0.5 --noise 0.1 --delay 0.025 --quantise \
    --seed 3 --out examples/hardware/disturbance_log.csv
run tensim check-log examples/hardware/disturbance_log.csv --model tetraspine3
run tensim --quiet compare examples/hardware/disturbance_log.csv --out "$out/compare"
# the same log with its load columns removed: replayed without the push, and warned about
grep -v '^# experiment' examples/hardware/disturbance_log.csv | python3 -c "
import csv, sys
rows = list(csv.reader(sys.stdin))
head = next(i for i, r in enumerate(rows) if r and r[0] == 'time_s')
keep = [k for k, name in enumerate(rows[head]) if not name.startswith('load_N/')]
w = csv.writer(sys.stdout, lineterminator='\n')
for r in rows:
    w.writerow(r if r and r[0].startswith('#') else [r[k] for k in keep])
" > "$out/no_loads.csv"
run tensim --quiet compare "$out/no_loads.csv" --out "$out/compare_no_loads"
run tensim --quiet sysid examples/hardware/disturbance_log.csv --fit-window 0:4 \
    --validate-window 4:7 --out "$out/sysid"
run tensim --quiet compare examples/hardware/disturbance_log.csv \
    --model "$out/sysid/fitted_structure.yaml" --sensor "$out/sysid/measurement.json" \
    --out "$out/compare_fitted"
run tensim --quiet sysid examples/hardware/sine_log.csv --fit-window 0:5 \
    --validate-window 5:8 --out "$out/sysid_sine"
run tensim --quiet sysid examples/hardware/disturbance_log.csv --params stiffness \
    --start stiffness=450 --max-sims 3 --out "$out/sysid_bad_start"
