"""Stand-ins for what cannot run here: the person and eye tracker, the EEG, the RViz view."""
