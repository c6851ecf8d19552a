"""Stand-ins for hardware: simulated person, eye tracker, EEG amplifier, RViz."""
