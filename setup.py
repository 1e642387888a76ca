"""Builds the optional compiled cable callback against the MuJoCo headers in its wheel."""

import os

import mujoco
from setuptools import Extension, setup

_INCLUDE = os.path.join(os.path.dirname(mujoco.__file__), "include")

setup(
    ext_modules=[
        Extension(
            "tensim.sim._cable",
            sources=["src/tensim/sim/_cable.c"],
            include_dirs=[_INCLUDE],
            extra_compile_args=["-O2", "-std=c99", "-ffp-contract=off"],
            # Without a C compiler tensim still works, through the (slower) Python callback.
            optional=True,
        )
    ]
)
