"""python -m rrr_robot: the rrr command line."""

from .cli import main

raise SystemExit(main())
