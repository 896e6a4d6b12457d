"""Exports of aromm objects to other libraries (each imported lazily: aromm never needs them)."""
