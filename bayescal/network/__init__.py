"""Whole networks: plans of pairs (CSV or SDS archive) run on Dask.

* :mod:`.plan`   reading a plan into items
* :mod:`.batch`  running them, resumable, and writing the tables and report

A shell: may import every layer below it (core, io, criticism, report).
"""
