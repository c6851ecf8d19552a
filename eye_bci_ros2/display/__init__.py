"""Windows a person looks at (the SSVEP stimulus window); pyglet, not part of the pure core."""
