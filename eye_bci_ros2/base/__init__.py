"""
What every layer uses: one declaration per setting and the value checks.

:mod:`.settings` declares each setting once (default, range, unit, description);
:mod:`.validators` holds the checks; :mod:`.output_files` checks a session's
output file before it starts and keeps its result in a named file when the
write fails at the end.  Pure; imports nothing else of the package,
and every other part may import it.
"""
