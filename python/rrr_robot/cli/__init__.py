"""The ``rrr`` command line (also ``python -m rrr_robot``): the top layer, and the only place with
argparse, output to the user and exit statuses. The library layers below log and raise.

app (the parser, ``main`` and ``rrr fmus``), writing (``rrr writing``), identify (``rrr identify``,
``rrr identify-experiment``), hil (``rrr hil``), sweep (``rrr sweep``). Each command imports the
library modules it runs when it runs, so ``rrr --help`` loads none of them.
"""

from .app import build_parser, main

__all__ = ["build_parser", "main"]
