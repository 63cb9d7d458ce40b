"""Shared test setup: headless plotting for everything the tests run, subprocesses included."""
import os

os.environ.setdefault("MPLBACKEND", "Agg")
