"""The writing task's closed loop as an SSP 1.0 system (System Structure and Parameterization)
that other co-simulation tools run: :mod:`.export` writes the archive (``rrr ssp``), with the
reference FMU playing the joint reference from a table (:mod:`.table`); :mod:`.archive` reads
and checks an archive; :mod:`.run` runs one in libcosim or FMPy (``rrr run-ssp``) and writes
the results in the format of ``rrr writing``."""
