"""The papers' own studies, outside the generic core: their numbers, phase names and shipped files.

* :mod:`aromm.studies.chavez2020`: the identification study of [Chavez2020, § 4] (Table 2, the +2 % study,
  accuracy against cost) on the wood VER;
* :mod:`aromm.studies.garnier_danes`: the bounds study of [GarnierDanes] (the Table 1 grid, preference maps).

Used by the notebooks and benchmarks; nothing in ``aromm`` or ``inverse`` imports it.
"""
