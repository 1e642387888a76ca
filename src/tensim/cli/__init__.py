"""The ``tensim`` command line: thin calls into the library.

Each subcommand lives in its own module of this package with a ``register(subparsers)``
function that adds its parser and sets ``run`` (a function of the parsed arguments that
returns the exit status). Modules import the heavy parts of the library inside ``run``, so
``tensim --help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys
from collections.abc import Callable, Sequence

from tensim import __version__

# subcommand modules, in the order ``tensim --help`` lists them
COMMAND_MODULES = (
    "tensim.cli.models",
    "tensim.cli.info",
    "tensim.cli.controller",
    "tensim.cli.simulate",
    "tensim.cli.experiment",
    "tensim.cli.export",
    "tensim.cli.view",
    "tensim.cli.render",
    "tensim.cli.io",
    "tensim.cli.learn",
    "tensim.cli.rl",
    "tensim.cli.hardware",
    "tensim.cli.bench",
    "tensim.cli.design",
    "tensim.cli.check",
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand."""
    parser = argparse.ArgumentParser(prog="tensim", description="Model, simulate, control and "
                                     "learn gaits for tensegrity robots on MuJoCo.")
    parser.add_argument("--version", action="version", version=f"tensim {__version__}")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.add_argument("--force", action="store_true",
                        help="run work past tensim's size limits (physics steps, recorded "
                             "samples; see tensim.limits)")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tensim`` console script; errors in the input exit with status 2."""
    from tensim._files import WriteError
    from tensim.cli._common import check_outputs, output_option_of
    from tensim.control import ControllerFileError, GaitError
    from tensim.model import ModelError
    from tensim.sim import SimulationError
    from tensim.structure import StructureError

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    args = build_parser().parse_args(argv)
    run: Callable[[argparse.Namespace], int] = args.run
    try:
        check_outputs(args)
        status = run(args)
        sys.stdout.flush()  # a reader that left (a broken pipe) shows here, not at exit
        return status
    except KeyboardInterrupt:  # every file tensim writes is complete or absent
        print("tensim: interrupted; the files written so far are complete, the rest were not "
              "written", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of our output left (`tensim ... | head`): not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second complaint
        return 0
    except WriteError as err:  # name the option and the cause in words, not [Errno 28]
        name = os.fsdecode(err.filename or "")
        option = output_option_of(args, name)
        message = (str(err) if option is None else
                   f"{option}: cannot be written ({err.strerror})" if option.endswith(" " + name)
                   else f"{option}: {err}")
        print(f"tensim: error: {message}", file=sys.stderr)
        return 2
    except (StructureError, ModelError, SimulationError, ControllerFileError, GaitError,
            KeyError, ValueError, OSError) as err:
        text = err.args[0] if isinstance(err, KeyError) and err.args else err
        print(f"tensim: error: {text}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
