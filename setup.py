"""Builds the optional compiled parts: the cable callback, against the MuJoCo headers in its
wheel, and the CPG integrator."""

import os

import mujoco
from setuptools import Extension, setup

_INCLUDE = os.path.join(os.path.dirname(mujoco.__file__), "include")
_FLAGS = ["-O2", "-std=c99", "-ffp-contract=off"]

setup(
    ext_modules=[
        Extension(
            "tensim.sim._cable",
            sources=["src/tensim/sim/_cable.c"],
            include_dirs=[_INCLUDE],
            extra_compile_args=_FLAGS,
            # Without a C compiler tensim still works, through the (slower) Python callback.
            optional=True,
        ),
        Extension(
            "tensim.control._cpg",
            sources=["src/tensim/control/_cpg.c"],
            extra_compile_args=_FLAGS,
            libraries=["m"],
            # Without a C compiler CPGs are integrated by scipy instead (about 20x slower).
            optional=True,
        ),
    ]
)
