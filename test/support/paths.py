"""Where the repository and its files are, for tests that read or run them."""

from pathlib import Path

#: The repository root (the folder holding package.xml).
REPO = Path(__file__).resolve().parents[2]
#: The package's config folder.
CONFIG = REPO / 'config'
