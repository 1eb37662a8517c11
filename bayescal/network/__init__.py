"""Whole networks: plans of pairs (CSV or SDS archive) run on Dask.

* :mod:`.plan`   reading a plan into items
* :mod:`.batch`  running them, resumable, and writing the tables and report

A shell: may import every layer below it (core, io, criticism, report).

Its public names (``__all__``) are loaded on first use
(:func:`lazy_loader.attach`): importing this package costs no import time.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "plan": ["default_options", "read_csv_plan", "sds_plan"],
    "batch": ["item_seed", "read_log", "run_batch"],
})
