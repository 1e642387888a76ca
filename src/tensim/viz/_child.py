"""The environment of the viz layer's helper processes (figure drawing, OpenGL painting)."""

from __future__ import annotations

import os

# The helpers do no linear algebra. numpy's OpenBLAS otherwise starts a thread per core when
# it loads, which costs each helper about 0.05 s of CPU time (more on a busy machine).
_ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}


def helper_env(**changes: str) -> dict[str, str]:
    """This process's environment with ``changes``, and one BLAS thread unless the user
    chose a number (the helper's own setting: this process's stays as it is)."""
    return {**_ONE_THREAD, **os.environ, **changes}
