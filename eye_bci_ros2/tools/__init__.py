"""Command-line tools: calibrate, describe the parameters, find the panel, watch the graph."""
