"""The ``mutual`` command line: the thesis's methods on your own data.

::

    mutual constraints infer DEMOS.csv --world WORLD.toml   # chapters 2-3
    mutual supervisor fit INTERVENTIONS.csv                 # chapter 4
    mutual study anova DATA.csv --dv COL --within COL --subject COL   # chapter 5
    mutual motion legible SPEC.toml                         # chapters 6-7

One module per command group (:mod:`.constraints`, :mod:`.supervisor`, :mod:`.study`,
:mod:`.motion`), each with ``register(subparsers)``; shared helpers in :mod:`.common`. Heavy
libraries (jax, hj-reachability, cvxpy) are imported inside the commands, so ``--help`` is fast.
The input formats are documented in ``data/README.md``.
"""

import argparse
import sys

from . import common, constraints, motion, study, supervisor

__all__ = ["build_parser", "main"]

GROUPS = (constraints, supervisor, study, motion)

EPILOG = """\
examples (the inputs are in data/examples/ of the repository):
  mutual constraints infer demonstrations.csv --world world.toml
  mutual supervisor fit interventions.csv --grid quick
  mutual study anova study.csv --dv value --within treatment --subject participant \\
      --where measure=false_positives --aggregate mean
  mutual motion legible legible.toml --out results/

Every command writes its files to --out (default: the current directory), prints a summary
(or one JSON object with --json) and exits with status 2 and a one-line message on bad input.
Input formats: data/README.md. Cite: CITATION.cff.
"""


def build_parser():
    """The argparse parser of ``mutual`` with every command group registered."""
    from .. import __version__
    parser = common.Parser(
        prog="mutual", formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Run the methods of 'Towards Mutual Understanding between Mortals and Machines in Motion "
                    "for Safety' (McPherson, 2022) on your own data.")
    parser.add_argument("--version", action="version", version=f"mutual {__version__}")
    groups = parser.add_subparsers(title="command groups", dest="group", metavar="GROUP", required=True)
    for group in GROUPS:
        group.register(groups)
    return parser


def main(argv=None):
    """Entry point of the ``mutual`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return common.run(args, args.prog)


if __name__ == "__main__":
    sys.exit(main())
