"""python -m rrr_robot: the rrr command line."""

from .cli import main

if __name__ == "__main__":  # not when a spawned worker process imports the main module again
    raise SystemExit(main())
