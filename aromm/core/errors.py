"""Exceptions of the toolkit.

The command line maps :class:`InputError` to exit code 2 and :class:`NumericalError`
to exit code 1; both carry a message meant for a person (what was wrong, where, and
what is allowed).
"""

from __future__ import annotations


class InputError(ValueError):
    """Bad input: a scene file, an image, a CSV or an argument is not acceptable.

    The message names the file (when there is one), the key or field, and the allowed values.
    """


class NumericalError(RuntimeError):
    """A numerical method failed: the message says which solver and why."""


class InputWarning(UserWarning):
    """An input could not be used as given and was replaced: the message says by what (never a silent clamp)."""


class ModelWarning(UserWarning):
    """A reduced model used where nothing bounds its error: outside its training box, at another value of a parameter
    it pinned, or short of its tolerance (the message says which and by how much)."""
