"""Hypothesis profiles: reproducible property tests by default and in CI, random exploration on request.

* ``ci`` (the default, and what ``.ci/run`` selects with ``--hypothesis-profile=ci``): derandomized (the
  examples depend on the test only, so a run is repeatable on every machine), no example database (a
  failure found once cannot be replayed into later runs of the same checkout), no deadline (timings on a
  shared 2-core machine are not a property of the code).
* ``explore``: random examples with the local database, for looking for new counterexamples
  (``HYPOTHESIS_PROFILE=explore python -m pytest`` or ``--hypothesis-profile=explore``); a counterexample
  found there becomes an explicit ``@example`` or a fixed test, never a stored replay.
"""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, database=None, deadline=None, print_blob=True)
settings.register_profile("explore", deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
