"""Recordings of real people (gaze, EEG) read into the core's arrays: pure loaders."""
