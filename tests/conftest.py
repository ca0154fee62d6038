"""Shared fixtures and markers for the whole suite.

The test tree mirrors the package (``tests/<package>/``); helpers shared by
several packages' tests live beside this file (``bus_support.py``), which pytest
puts on the import path.
"""
