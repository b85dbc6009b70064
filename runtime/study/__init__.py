"""Studies over many runs: sweeps on Dask (:mod:`.sweep`), the metrics of a run
(:mod:`.metrics`) and the EN 1990 checks (:mod:`.en1990`)."""
