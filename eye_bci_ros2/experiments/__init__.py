"""Experiments on the running system: the demo, the accuracy test, pictures and metrics."""
