"""Physics beyond conduction alone, each built as an affine system of the thermal kind (:mod:`aromm.core.system`)."""
