"""docs/: the manual and the repository's habits, fast: the docs map, the Python API page, the
habits (licence, pre-commit, CONTRIBUTING, no wall-clock bound), the test layout. No marker
(the fast subset); the manual's blocks run in docs/blocks/ (slow)."""

from support.markers import folder_markers

pytest_ignore_collect = folder_markers(__file__)
