"""Independent points spread over local processes or Dask (``executor.py``), with results kept per point so that a
rerun resumes (``point_results.py``)."""
