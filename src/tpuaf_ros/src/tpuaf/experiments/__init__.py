"""Experiments: results folders, Dask sweeps, plots and the comparison report."""
