"""The ``bayescal`` command: a thin dispatcher over its sub-commands.

Each sub-command is a module of this package named in ``COMMANDS`` and
defining ``HELP`` (one line), ``configure(parser)`` and ``run(args) -> int``:
:mod:`.fit`, :mod:`.report`, :mod:`.diagnose`, :mod:`.windows`, :mod:`.noise`, :mod:`.cal`,
:mod:`.uvw` and :mod:`.batch`; :mod:`.common` holds what several of them
share. This is the top layer: it may import every other subpackage, and
nothing imports it. Errors a user can fix (bad files, no overlap, too little
data...) end with one line on stderr and exit code 2, never a traceback.

Its public names (``__all__``) are loaded on first use
(:func:`lazy_loader.attach`): importing this package costs no import time.
"""
from __future__ import annotations

import argparse
import importlib
import sys

import lazy_loader

from ..version import __version__

#: The sub-commands, in the order ``bayescal --help`` lists them.
COMMANDS = ("fit", "report", "diagnose", "windows", "noise", "uvw", "cal", "batch")

__getattr__, _, _LAZY_NAMES = lazy_loader.attach(__name__, submod_attrs={
    "fit": ["print_summary", "response_lines"],
})
__all__ = sorted([*_LAZY_NAMES, "COMMANDS", "build_parser", "main"])


def __dir__():
    """The public names, those defined here included."""
    return list(__all__)


def _user_errors():
    from ..errors import FitError, InputError, ResponseError, SpectraError
    return (InputError, SpectraError, FitError, ResponseError)


def build_parser():
    parser = argparse.ArgumentParser(
        prog="bayescal",
        description="Bayesian calibration of seismometers: orientation and response of a sensor "
                    "under test from recordings beside a known reference, with credible "
                    "intervals you can trust.")
    parser.add_argument("--version", action="version", version=f"bayescal {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        mod = importlib.import_module(f"{__name__}.{name}")
        p = sub.add_parser(name, help=mod.HELP, description=mod.__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        mod.configure(p)
        p.set_defaults(command_run=mod.run)
    return parser


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    args.own_process = argv is None     # the console command: the process ends with it
    if not getattr(args, "command_run", None):
        parser.print_help()
        return 2
    try:
        return int(args.command_run(args) or 0)
    except _user_errors() as exc:
        print(f"bayescal: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bayescal: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
