"""Tooth geometry: profiles, deviations and their feasibility checks."""
