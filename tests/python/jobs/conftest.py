"""jobs/: the rrr commands end to end: writing (figures, animations, text layout, plan cache,
outputs, progress, MCAP, the browser view, the notebook), identification, sweeps (Dask), SSP
archives, the CLI's errors and hostile inputs, the bench scripts' extra. Marker ``slow``."""

from support.markers import folder_markers

pytest_ignore_collect = folder_markers(__file__, "slow")
