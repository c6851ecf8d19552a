"""Command-line tools (calibration, description, ...)."""
