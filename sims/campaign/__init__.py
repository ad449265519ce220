"""Monte Carlo campaigns: the engine on Dask, its chunk files, the scenario task, statistics and envelopes."""
