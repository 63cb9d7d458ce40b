"""Builders that turn reducer specifications (data) into Exudyn systems."""
