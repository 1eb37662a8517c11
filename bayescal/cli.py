"""The ``bayescal`` command: a thin dispatcher over ``bayescal.commands``.

Each command is a module in :mod:`bayescal.commands` defining ``HELP`` (one
line), ``configure(parser)`` and ``run(args) -> int``. Errors a user can fix
(bad files, no overlap, too little data...) end with one line on stderr and
exit code 2, never a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from . import __version__

#: Order in which commands are listed in ``bayescal --help``.
ORDER = ("fit", "report", "diagnose", "uvw", "batch")


def _user_errors():
    from .fit import FitError
    from .io import InputError
    from .response import ResponseError
    from .spectra import SpectraError
    return (InputError, SpectraError, FitError, ResponseError)


def build_parser():
    from . import commands
    parser = argparse.ArgumentParser(
        prog="bayescal",
        description="Bayesian calibration of seismometers: orientation and response of a sensor "
                    "under test from recordings beside a known reference, with credible "
                    "intervals you can trust.")
    parser.add_argument("--version", action="version", version=f"bayescal {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    names = [m.name for m in pkgutil.iter_modules(commands.__path__)]
    for name in sorted(names, key=lambda n: (ORDER.index(n) if n in ORDER else len(ORDER), n)):
        mod = importlib.import_module(f"bayescal.commands.{name}")
        p = sub.add_parser(name, help=mod.HELP, description=mod.__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        mod.configure(p)
        p.set_defaults(_run=mod.run)
    return parser


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    try:
        return int(args._run(args) or 0)
    except _user_errors() as exc:
        print(f"bayescal: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bayescal: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
