"""``tensim calibrate-loadcell``, ``compare``, ``sysid``, ``make-log`` and ``check-log``: the
reality gap.

Calibrate the load cells (eq. 7), compare a hardware log with its replay in simulation, fit
the model's uncertain parameters to logs, and write simulated logs for demos and tests.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tensim.cli._common import (
    Progress,
    add_controller_option,
    add_world_options,
    count,
    finite,
    load_model,
    natural,
    nonnegative,
    output_option,
    positive,
    world_from_args,
)

if TYPE_CHECKING:
    from tensim.hardware import HardwareLog

_DEFAULT_CONTROLLER = "tetraspine3_impedance"


def register(sub: argparse._SubParsersAction) -> None:
    _register_calibrate(sub)
    _register_compare(sub)
    _register_sysid(sub)
    _register_make_log(sub)
    _register_check_log(sub)


def _add_log_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", default="tetraspine3", help="preset or structure .yaml file")
    add_controller_option(p, _DEFAULT_CONTROLLER)
    p.add_argument("--loadcell", default=None, metavar="JSON",
                   help="calibration for adc/ columns (from calibrate-loadcell; default: the "
                        "log header's, else the paper's eq. 7)")
    p.add_argument("--skip", type=nonnegative, default=0.0,
                   help="leave the log's first seconds out of the error figures [s]")
    p.add_argument("--settle", type=float, default=1.0,
                   help="the 'after settling' max-tension figures start here [s] (the t = 0 "
                        "sample is the build pretension, the same in both by construction)")
    add_world_options(p)


# -- calibrate-loadcell -------------------------------------------------------------------------


def _register_calibrate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("calibrate-loadcell", help="fit force = a ADC + b to calibration pairs",
                       description="Fits the load-cell line of the paper's eq. (7) to a CSV of "
                       "'adc,force_N' pairs; writes calibration.json and calibration.png, and "
                       "converts raw logs' adc/ columns to tension_N/.")
    p.add_argument("pairs", help="CSV with the columns adc,force_N")
    output_option(p, "--out", "folder", default="runs/calibration", help="output folder")
    p.add_argument("--max-force", type=positive, default=111.21,
                   help="largest measurable tension [N] (Tetraspine3: 111.21)")
    p.add_argument("--convert", nargs="*", default=[], metavar="LOG",
                   help="hardware logs with adc/ columns to convert to newtons into --out")
    p.set_defaults(run=_calibrate)


def _calibrate(args: argparse.Namespace) -> int:
    from tensim.hardware import convert_log, fit_loadcell, read_log, read_pairs, write_log
    from tensim.hardware.loadcell import save_calibration
    from tensim.hardware.plots import plot_calibration
    from tensim.runs import check_run_folder, replace_folder

    out = Path(args.out)
    check_run_folder(out)
    fit = fit_loadcell(*read_pairs(args.pairs), max_force=args.max_force)
    logs = [(source, convert_log(read_log(source), fit.loadcell)) for source in args.convert]
    with replace_folder(out) as stage:
        plot_calibration(fit, stage / "calibration.png")
        for source, log in logs:
            name = f"{Path(source).stem}_newtons.csv"
            write_log(log, stage / name)
            print(f"converted {source} -> {out / name}")
        save_calibration(fit, stage / "calibration.json")
    s = fit.summary()
    print(f"{s['equation']}  (a ± {s['gain_stderr_N_per_count']:.2g}, b ± "
          f"{s['offset_stderr_N']:.2g} N, {s['pairs']} pairs, R² = {s['r_squared']:.6f})")
    print(f"resolution {s['resolution_N']:.4f} N per count; residuals RMS "
          f"{s['residual_rms_N']:.4f} N, max {s['residual_max_N']:.4f} N")
    print(f"wrote {out}/ (calibration.json, calibration.png)")
    return 0


# -- compare ------------------------------------------------------------------------------------


def _register_compare(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="hardware log vs its replay in simulation",
                       description="Replays a hardware log's V* (or the controller's gait) in "
                       "simulation, aligns the tensions in time and reports the paper's error "
                       "figures: DIR/summary.json and DIR/report.html with the overlays.")
    p.add_argument("log", help="hardware log CSV (see docs/hardware.md)")
    _add_log_options(p)
    p.add_argument("--sim", default=None, metavar="RUN",
                   help="compare with an existing simulated run (a run folder or its "
                        "trajectory.parquet) instead of replaying")
    p.add_argument("--sensor", default=None, metavar="JSON",
                   help="measurement model from sysid (measurement.json): gain, offset, delay "
                        "and V* scale applied to the simulation")
    p.add_argument("--offset", type=finite, default=None,
                   help="lag of the log behind the simulation [s] (default: the --sensor "
                        "delay, else estimated by cross-correlation)")
    p.add_argument("--max-offset", type=positive, default=0.5,
                   help="largest lag the estimate tries [s]")
    output_option(p, "--out", "folder", default="runs/compare", help="output folder")
    p.set_defaults(run=_compare)


def _compare(args: argparse.Namespace) -> int:
    from tensim.hardware import compare_tensions, load_calibration, load_log, replay
    from tensim.hardware.compare import displacement_errors
    from tensim.hardware.logs import check_items
    from tensim.hardware.report import write_comparison
    from tensim.hardware.sensor import load_measurement
    from tensim.model import compile_structure
    from tensim.models import load_controller
    from tensim.runs import replace_folder
    from tensim.sim import TimeSeries

    log = load_log(args.log, load_calibration(args.loadcell) if args.loadcell else None)
    _warn_jumps(log)
    sensor, vstar_scale = load_measurement(args.sensor) if args.sensor else (None, 1.0)
    structure = load_model(args.model)
    check_items(log, structure)
    if args.sim:
        path = Path(args.sim)
        simulated = TimeSeries.from_parquet(path / "trajectory.parquet" if path.is_dir()
                                            else path)
    else:
        config = load_controller(args.controller, structure)
        simulated = replay(log, structure, config, world=world_from_args(args),
                           vstar_scale=vstar_scale, margin=args.max_offset,
                           progress=Progress("replay", args.quiet)).trajectory
    comparison = compare_tensions(log, simulated, sensor=sensor, offset=args.offset,
                                  max_offset=args.max_offset, skip=args.skip,
                                  settle=args.settle)
    mocap = displacement_errors(log, simulated, compile_structure(
        structure, world_from_args(args)), comparison.offset_s) if log.cables("mocap_x") \
        else None
    info = {"log": args.log, "model": args.model, "controller": args.controller,
            "simulation": args.sim or "replayed", "sensor": args.sensor, "dt_s": args.dt}
    out = Path(args.out)
    with replace_folder(out) as stage:
        summary = write_comparison(stage, comparison, info, f"{Path(args.log).name}: hardware "
                                   "vs simulation", mocap)
    print(f"wrote {out}/ (summary.json, report.html, overlay.png)")
    _print_comparison(summary)
    for node, error in (mocap or {}).items():
        print(f"  {node}: RMS displacement error {1000 * error:.1f} mm (motion capture)")
    return 0


SHOWN = 5  # warnings of one kind printed per log; the rest are counted


def _warn_jumps(log: HardwareLog) -> None:
    """Warns on standard error of tension jumps and drifts that no logged load explains."""
    from tensim.hardware.checklog import summarize_log

    summary = summarize_log(log)
    lines = _load_warnings(summary)
    for line in lines:
        print(f"warning: {log.source}: {line}", file=sys.stderr)
    if lines:
        print(f"warning: {log.source}: {_jump_hint(summary)}", file=sys.stderr)


def _jump_hint(summary: dict) -> str:
    """What unexplained jumps suggest: a push the log lacks, or (it records its loads) noise
    or an event between them."""
    if summary["missing_push"]:
        return ("a push the log does not record? (load_N/<node>/<axis> columns or an "
                "'# experiment:' header)")
    return "the log records its loads, so these are sensor noise or an event they leave out"


def _load_warnings(s: dict) -> list[str]:
    """The jump and drift warnings of a log summary, ``SHOWN`` of each and a count of the
    rest."""
    jumps = [f"tensions jump at {j['time_s']:g} s ({', '.join(j['cables'])}) where no logged "
             "load changes" for j in s["unexplained_jumps"]]
    drifts = [f"tensions drift by up to {d['largest_N']:.3g} N over {d['start_s']:g}-"
              f"{d['end_s']:g} s ({', '.join(d['cables'])}) where no logged load acts"
              for d in s["unexplained_drifts"]]
    out = []
    for lines, what in ((jumps, "jumps"), (drifts, "drifts")):
        out += lines[:SHOWN]
        if len(lines) > SHOWN:
            out.append(f"... and {len(lines) - SHOWN} more {what} ({len(lines)} in all; "
                       "--json lists them)")
    return out


def _print_comparison(s: dict) -> None:
    def f(key: str, spec: str, scale: float = 1.0) -> str:
        return "n/a" if s[key] is None else format(scale * s[key], spec)

    print(f"error on the max system tension {f('max_system_tension_error_percent', '+.2f')} % "
          f"(hardware {f('max_system_tension_hardware_N', '.2f')} N, simulation "
          f"{f('max_system_tension_simulated_N', '.2f')} N); after {s['settle_s']:g} s "
          f"{f('max_settled_system_tension_error_percent', '+.2f')} %"
          + ("" if s["load_window_s"] is None else
             f"; under load ({s['load_window_s'][0]:g}-{s['load_window_s'][1]:g} s) "
             f"{f('max_loaded_system_tension_error_percent', '+.2f')} %"))
    print(f"time offset {f('time_offset_s', '.1f', 1000)} ms ({s['time_offset_from']})")
    print(f"RMSE {f('rmse_N', '.3f')} N, correlation {f('correlation', '.3f')}, pretension "
          f"offset {f('pretension_offset_N', '+.3f')} N, amplitude ratio "
          f"{f('amplitude_ratio', '.3f')}")


# -- sysid --------------------------------------------------------------------------------------


# the names and units of tensim.hardware.parameters.DEFINITIONS, spelt out so that building the
# parser imports no simulation code (tests check the two agree)
SYSID_PARAMETERS = ("friction [-], stiffness [N/m], damping [N s/m], max_speed [m/s], "
                    "stall_torque [N m], no_load_speed [rad/s], rotor_inertia [kg m^2], "
                    "coulomb_friction [N m], viscous_friction [N m s/rad], "
                    "torsional_friction [m], rolling_friction [m], "
                    "mass_scale [-], vstar_scale [-], offset [N], gain [-], delay [s]")


def _register_sysid(sub: argparse._SubParsersAction) -> None:
    names = SYSID_PARAMETERS
    p = sub.add_parser("sysid", help="fit model parameters to hardware logs",
                       description=f"Fits named parameters ({names}) to minimise the tension "
                       "error across the logs; writes the fitted structure, measurement.json, "
                       "report.html and summary.json.")
    p.add_argument("logs", nargs="+", help="hardware log CSVs")
    p.add_argument("--params", default="stiffness,friction,offset,delay",
                   help="comma-separated parameters to fit (default: "
                        "stiffness,friction,offset,delay)")
    p.add_argument("--fit-window", default=None, metavar="A:B",
                   help="fit on the samples from A to B seconds after each log's start "
                        "(default: all but a held-out quarter placed where the tensions "
                        "change)")
    p.add_argument("--validate-window", default=None, metavar="C:D",
                   help="judge the fit on these samples (default: the samples the fit "
                        "leaves out, or a quarter of the log where the tensions change); "
                        "without "
                        "--fit-window the fit uses the samples before C (after D if C is 0); "
                        "a fit worse than the nominal model there is not saved")
    p.add_argument("--force", action="store_true",
                   help="save the fit even if it is worse than the nominal model")
    p.add_argument("--bounds", default=None, help="e.g. friction=0.02:0.3,stiffness=150:350")
    p.add_argument("--start", default=None, help="starting values, e.g. friction=0.1")
    _add_log_options(p)
    p.add_argument("--max-sims", type=count, default=60,
                   help="budget of simulations per log (each one replays the whole log)")
    p.add_argument("--diff-step", type=positive, default=0.05,
                   help="finite-difference step of the physical parameters while fitting, as a "
                        "fraction of each bound range (the measurement parameters take central "
                        "differences of 0.1 %%, and the error bars central differences of this "
                        "step)")
    p.add_argument("--max-offset", type=nonnegative, default=0.5,
                   help="largest time offset the nominal model's alignment tries while "
                        "'delay' is not fitted [s] (0: the log's clock is the simulation's)")
    output_option(p, "--out", "folder", default="runs/sysid", help="output folder")
    p.set_defaults(run=_sysid)


def _sysid(args: argparse.Namespace) -> int:
    from tensim.hardware import SysidSettings, identify, load_calibration, load_log
    from tensim.hardware.parameters import parse_assignments, parse_bounds
    from tensim.hardware.report import write_sysid
    from tensim.models import load_controller
    from tensim.runs import replace_folder

    loadcell = load_calibration(args.loadcell) if args.loadcell else None
    logs = [load_log(path, loadcell) for path in args.logs]
    structure = load_model(args.model)
    config = load_controller(args.controller, structure)
    for log in logs:
        _warn_jumps(log)
    names = [n.strip() for n in args.params.split(",") if n.strip()]
    progress = Progress("sysid", args.quiet, unit="sims", rate_label=" sims/s")
    result = identify(logs, structure, config, names, bounds=parse_bounds(args.bounds),
                      start=parse_assignments(args.start, "--start"),
                      world=world_from_args(args), progress=progress,
                      settings=SysidSettings(
                          max_simulations=args.max_sims, diff_step=args.diff_step,
                          max_offset=args.max_offset, skip=args.skip, force=args.force,
                          fit_window=_window(args.fit_window, "--fit-window"),
                          validate_window=_window(args.validate_window, "--validate-window")))
    if not args.quiet and progress.tty:
        print(file=sys.stderr)  # end the progress bar's line if the budget was not used up
    info = {"logs": list(args.logs), "model": args.model, "controller": args.controller,
            "dt_s": args.dt, "max_sims": args.max_sims, "diff_step": args.diff_step,
            "fit_window": args.fit_window, "validate_window": args.validate_window}
    out = Path(args.out)
    with replace_folder(out) as stage:
        summary = write_sysid(stage, result, args.logs, info)
    print(f"wrote {out}/ (fitted_structure.yaml, measurement.json, report.html, summary.json)")
    print(f"{result.simulations} simulations; fitted vs nominal:")
    for name, p in summary["parameters"].items():
        error = "" if p["ci95"] is None else f" ± {p['ci95']:.3g}"
        print(f"  {name:<12} {p['fitted']:10.5g}{error} {p['unit']:<6} (nominal "
              f"{p['nominal']:.5g})")
    u = summary["uncertainty"]
    if result.kept_nominal:
        print("  (refused below: no interval is claimed for these values)")
    else:
        taus = ", ".join(f"{t:.2g}" for t in u["correlation_time_s"])
        print(f"  (±: 95 % interval; {u['samples']} readings, correlated over {taus} s: "
              f"{u['effective_samples']:.3g} effective, x{u['factor']:.2f}; see "
              "docs/hardware.md)")
    v = summary["validation"]
    window = v["window_s"]
    where = "fit samples" if v["on_fit_data"] else \
        f"validation samples {window[0]:g}:{window[1]:g} s"
    print(f"RMSE on the {where}: nominal {v['nominal_rmse_N']:.3f} N, fitted "
          f"{v['fitted_rmse_N']:.3f} N")
    print(f"|error| on the max system tension after settling (mean over the logs; compare "
          f"prints it signed) "
          f"{summary['max_settled_system_tension_error_before_percent']:.2f} % -> "
          f"{summary['max_settled_system_tension_error_after_percent']:.2f} % (whole run "
          f"{summary['max_system_tension_error_before_percent']:.2f} % -> "
          f"{summary['max_system_tension_error_after_percent']:.2f} %; all samples)")
    if result.kept_nominal:
        print("the fit is WORSE than the nominal model there: the nominal model was written "
              "instead (--force writes the fit)")
        return 0
    elif v["fitted_rmse_N"] > v["nominal_rmse_N"]:
        print("the fit is worse than the nominal model there; written because of --force")
    if v["on_fit_data"]:
        print("not checked on held-out samples (the fit window spans the whole log), so not "
              "recommended: give a --fit-window that leaves samples out, or a "
              "--validate-window")
        return 0
    if not v["excited"]:
        print(f"not recommended: the validation samples {window[0]:g}:{window[1]:g} s barely "
              f"move (excitation {v['excitation']:.2g} of the log's mean), so every model "
              "that holds the pretension scores alike there; give a --validate-window over a "
              "stretch where the tensions change")
        return 0
    print(f"use it: tensim compare {args.logs[0]} --model {out}/fitted_structure.yaml "
          f"--sensor {out}/measurement.json (replays the log's V* and loads)")
    return 0


def _window(text: str | None, option: str) -> tuple[float, float] | None:
    if text is None:
        return None
    low, sep, high = text.partition(":")
    try:
        window = (float(low), float(high))
    except ValueError:
        window = None
    if not sep or window is None or not window[0] < window[1]:
        raise ValueError(f"{option}: expected A:B seconds with A < B, got {text!r}")
    return window


# -- make-log -----------------------------------------------------------------------------------


def _register_make_log(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("make-log", help="write a simulated hardware log (demos, tests)",
                       description="Simulates a controller file and logs it at the robot's "
                       "rates (V* every 10 ms, feedback every 200 ms) through a sensor model; "
                       "--set gives the 'hardware' other physical parameters than the model.")
    p.add_argument("--model", default="tetraspine3", help="preset or structure .yaml file")
    add_controller_option(p, "tetraspine3_sine")
    p.add_argument("--duration", type=positive, default=10.0, help="logged time [s]")
    p.add_argument("--set", default=None,
                   help="physical parameters of the simulated hardware, e.g. "
                        "friction=0.1,stiffness=252")
    p.add_argument("--offset", type=finite, default=0.0, help="load-cell offset [N]")
    p.add_argument("--gain", type=positive, default=1.0, help="load-cell gain [-]")
    p.add_argument("--noise", type=nonnegative, default=0.0, help="reading noise std [N]")
    p.add_argument("--delay", type=nonnegative, default=0.0, help="readings lag the commands [s]")
    p.add_argument("--quantise", action="store_true",
                   help="quantise readings to the load cell's counts (eq. 7: 0.1567 N)")
    p.add_argument("--adc", action="store_true", help="log raw adc/ counts (implies --quantise)")
    p.add_argument("--mocap", default="", help="comma-separated nodes to log positions of")
    p.add_argument("--seed", type=natural, default=0, help="seed of the sensor noise")
    p.add_argument("--command-period", type=positive, default=0.01, help="V* period [s]")
    p.add_argument("--feedback-period", type=positive, default=0.2, help="feedback period [s]")
    p.add_argument("--experiment", default=None, metavar="NAME",
                   help="a built-in protocol whose loads act and are logged: disturbance "
                        "(the paper's Fig. 3 push) or sine (no loads)")
    p.add_argument("--experiment-params", default=None, metavar="K=V,...",
                   help="its parameters, e.g. peak=22.56,start=30,rise=5,hold=5,fall=5 "
                        "(the disturbance defaults)")
    add_world_options(p)
    output_option(p, "--out", "file", required=True, help="output CSV")
    p.set_defaults(run=_make_log)


def _make_log(args: argparse.Namespace) -> int:
    import numpy as np

    from tensim.hardware import PAPER_LOADCELL, SensorModel, simulated_log, write_log
    from tensim.hardware.loads import experiment_params
    from tensim.hardware.parameters import parse_assignments
    from tensim.limits import check_run
    from tensim.models import load_controller

    check_run(args.duration, args.dt, args.command_period, force=args.force)
    structure = load_model(args.model)
    config = load_controller(args.controller, structure)
    quantise = args.quantise or args.adc
    sensor = SensorModel(offset=args.offset, gain=args.gain, noise=args.noise, delay=args.delay,
                         loadcell=PAPER_LOADCELL if quantise else None)
    log = simulated_log(structure, config, args.duration,
                        parameters=parse_assignments(args.set, "--set"), sensor=sensor,
                        rng=np.random.default_rng(args.seed), adc=args.adc,
                        command_period=args.command_period,
                        feedback_period=args.feedback_period,
                        mocap_nodes=[n.strip() for n in args.mocap.split(",") if n.strip()],
                        world=world_from_args(args), progress=Progress("make-log", args.quiet),
                        experiment=None if args.experiment is None else (
                            args.experiment, experiment_params(
                                args.experiment, args.experiment_params, "--experiment-params")))
    log = dataclasses.replace(log, meta={**log.meta, "controller": args.controller,
                                         "seed": str(args.seed)})
    path = write_log(log, args.out)
    rows = log.series.time.size
    print(f"wrote {path}: {rows} rows ({args.duration} s), {len(log.series.channels)} columns; "
          f"parameters {log.meta['parameters']}; sensor {log.meta['sensor']}")
    return 0


# -- check-log ----------------------------------------------------------------------------------


def _register_check_log(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("check-log", help="validate and summarise hardware logs (no simulation)",
                       description="Reads and validates each log, then prints its duration, "
                       "channels and rates, gaps, external loads, experiment, and tension "
                       "jumps no logged load explains.")
    p.add_argument("logs", nargs="+", help="hardware log CSVs")
    p.add_argument("--model", default=None,
                   help="also check the columns' cables and nodes against this preset or "
                        "structure .yaml")
    p.add_argument("--json", action="store_true", help="print the summaries as JSON")
    p.set_defaults(run=_check_log)


def _check_log(args: argparse.Namespace) -> int:
    import json

    from tensim.hardware import load_log
    from tensim.hardware.checklog import summarize_log
    from tensim.hardware.loads import loads_for
    from tensim.hardware.logs import check_items

    structure = load_model(args.model) if args.model else None
    status = 0
    for path in args.logs:
        log = load_log(path)  # validated; adc/ columns converted (header calibration, eq. 7)
        if structure is not None:
            check_items(log, structure)
            loads_for(log, structure)
        s = summarize_log(log)
        status = status if s["valid"] else 1  # a log missing its push: exit status 1
        if args.json:
            print(json.dumps(s))
            continue
        print(f"{path}: {s['duration_s']:g} s, {s['rows']} rows")
        for quantity, q in s["quantities"].items():
            rate = "" if q["period_s"] is None else \
                f" every {q['period_s']:g} s (largest gap {q['max_gap_s']:g} s)"
            print(f"  {quantity}: {q['items']} items, {q['samples']} samples{rate}")
        if s["experiment"]:
            print(f"  experiment: {s['experiment']['name']} "
                  f"({', '.join(f'{k}={v:g}' for k, v in s['experiment']['params'].items())})")
        for node, peak in s["loads"].items():
            print(f"  load on {node}: peak {peak:g} N")
        if s["load_window_s"]:
            print(f"  loads act {s['load_window_s'][0]:g}-{s['load_window_s'][1]:g} s "
                  f"(from the {s['loads_from']})")
        for line in _load_warnings(s):
            print(f"  warning: {line}")
        if not s["valid"]:
            print(f"  NOT valid: {_jump_hint(s)}; compare and sysid would replay it without "
                  "its push")
            continue
        print("  valid" + (f" for {args.model}" if structure is not None else ""))
    return status
