"""Monte Carlo scenario sweeps of the writing task on Dask, results in Parquet (``rrr sweep``):
a job layer beside hil and identify, above writing.

spec (the sweep spec file), keys (what a sweep can vary: scenario fields by dotted name),
sampling (each run's values, from the spec and the run's index only), runs (one run on a
worker: a scenario with some fields changed, through the writing job's pieces), execution (the
batches on a Dask cluster), results (the Parquet dataset, one part per batch), sensitivity (the
ranking of the inputs), figures, job (the sweep end to end: ``run_sweep``). Needs the
``sweep`` extra (dask, distributed, pyarrow).
"""
