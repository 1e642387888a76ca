"""The library's plotting modules draw on their own Figure objects: importing them and drawing
neither loads pyplot nor changes the user's matplotlib backend."""

from __future__ import annotations

import os
import subprocess
import sys

_PROBE = """
import sys
from pathlib import Path
import matplotlib
import numpy as np
import tensim.hardware.plots, tensim.learn.plots, tensim.viz.drawing, tensim.viz.plots
from tensim.sim import TimeSeries
t = np.linspace(0.0, 1.0, 11)
series = TimeSeries(t, {"pos_x/a": t, "pos_y/a": t ** 2})
tensim.viz.plots.plot_path(series, Path(sys.argv[1]) / "path.png")
print(matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules)
"""


def test_plotting_modules_keep_the_users_backend_and_never_load_pyplot(tmp_path):
    env = {**os.environ, "MPLBACKEND": "svg"}  # the user's choice, which tensim must keep
    out = subprocess.run([sys.executable, "-c", _PROBE, str(tmp_path)], capture_output=True,
                         text=True, check=True, env=env).stdout.split()
    assert out == ["svg", "False"]
    assert (tmp_path / "path.png").read_bytes()[:4] == b"\x89PNG"
