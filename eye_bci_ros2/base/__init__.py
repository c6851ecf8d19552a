"""
What every layer uses: one declaration per setting and the value checks.

:mod:`.settings` declares each setting once (default, range, unit, description);
:mod:`.validators` holds the checks.  Pure; imports nothing else of the package,
and every other part may import it.
"""
