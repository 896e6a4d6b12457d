"""The core: the affine ThermalSystem, the scene vocabulary, profiles, observables, errors, files, cache, resources
(imports nothing else of aromm)."""
