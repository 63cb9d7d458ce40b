"""Operating protocols (boundary conditions, load histories, sampling) applied to assembled models."""
