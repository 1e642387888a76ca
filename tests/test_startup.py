"""Start-up stays light: building the command line loads no plotting or scientific stack.

The figures (``tensim --help`` in about a quarter second) come from ``benchmarks/startup.py``;
here only what is imported is checked, which is what makes them fast.
"""

from __future__ import annotations

import subprocess
import sys

from tensim.cli.hardware import SYSID_PARAMETERS

_PROBE = """
import sys
import tensim.cli
tensim.cli.build_parser()
print(" ".join(sorted({m.split(".")[0] for m in sys.modules})))
"""


def test_building_the_parser_imports_neither_scipy_nor_matplotlib():
    out = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True,
                         check=True).stdout.split()
    # each of these costs 0.1-0.5 s to import; a command loads them only when it runs
    assert not {"scipy", "matplotlib", "ray", "cma", "av", "OpenGL"} & set(out)


def test_import_tensim_does_not_load_scipy():
    probe = "import sys, tensim; print('scipy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"


def test_the_presets_and_the_main_experiments_load_no_scipy():
    # the 3-bar and SUPERball presets turn a face down with scipy's Rotation when built:
    # the registry that lists them must not load it for every command (0.25 s, 30 MiB)
    probe = ("import sys, tensim.models, tensim.experiments.disturbance, "
             "tensim.experiments.gait; print('scipy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"


def test_the_sysid_help_lists_every_parameter_with_its_unit():
    from tensim.hardware.parameters import DEFINITIONS

    assert SYSID_PARAMETERS == ", ".join(f"{d.name} [{d.unit}]" for d in DEFINITIONS.values())


def test_output_cut_short_by_its_reader_is_not_an_error():
    # `tensim models | head -1`: the reader leaves before tensim has printed everything
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from tensim.cli import main; "
                             "sys.exit(main(['models']))"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()  # the reader is gone before tensim writes
    error = proc.stderr.read().decode()
    assert proc.wait() == 0, error
    assert "Broken pipe" not in error and "BrokenPipeError" not in error


def test_the_pre_run_check_and_slack_cables_load_no_scipy_optimizer():
    # scipy.optimize pulls in linprog's chain (scipy.fft, scipy.special...): 0.2-0.3 s of CPU
    # that `tensim simulate` paid for its pre-run check, which solves nothing, and for the sag
    # of a slack cable in frame.png
    probe = ("import sys, numpy as np, tensim.design\n"
             "from tensim.design.check import check_structure\n"
             "from tensim.models import preset\n"
             "from tensim.viz.cables import sag_depth\n"
             "check_structure(preset('prism3').build(), 1e-3)\n"
             "sag_depth(np.array([0.3]), np.array([0.31]))\n"
             "print('scipy.optimize' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"


def test_the_rolling_presets_stand_without_the_design_tools_or_scipy():
    # their standing pose is stored data (tensim.models._standing): built with their default
    # arguments they solve nothing (the statics solve and scipy's import were 0.4 s of CPU)
    probe = ("import sys; from tensim.models import six_bar, superball, three_bar; "
             "six_bar(); superball(); three_bar(); "
             "print(sorted(m for m in ('scipy', 'tensim.design') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]"
