"""Command-line tools: calibration fitting and parameter documentation."""
