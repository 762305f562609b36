"""Spine-stiffness studies: a spec expanded into trials, one record per trial (resumable), local or Dask
execution, bootstrap statistics and a report. `sparc-quad study run|report` is the command line."""
