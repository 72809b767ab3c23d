"""The shipped scenes: YAML files read as package data (``autobal list``)."""
