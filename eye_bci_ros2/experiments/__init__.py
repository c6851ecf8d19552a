"""Experiments: demo, accuracy test, pictures and the metrics they report."""
