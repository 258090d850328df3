"""docs/blocks/: every command and code block of README.md and docs/ runs as written
(support/doc_blocks.py says how). Marker ``slow``."""

from support.markers import folder_markers

pytest_ignore_collect = folder_markers(__file__, "slow")
