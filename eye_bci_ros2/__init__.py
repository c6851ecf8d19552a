"""Choose among RViz markers by looking at them: gaze over LSL, projection, arbitration."""
