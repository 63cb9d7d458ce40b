"""Contact sets: specifications (data), evaluation backends and assembly."""
