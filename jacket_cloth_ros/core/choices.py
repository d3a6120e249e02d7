# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Enums for choices that parameters name as strings (``hard_pass``, ``xpbd``, ``lz4``)."""

import enum


class Choice(enum.IntEnum):
    """An enum whose members a parameter names in lower case (``hard_pass``)."""

    @classmethod
    def names(cls) -> tuple:
        """Return the parameter values, in the enum's order."""
        return tuple(m.name.lower() for m in cls)

    @classmethod
    def parse(cls, text: str, what: str) -> 'Choice':
        """Return the member named ``text``; else ValueError naming ``what`` and the choices.

        :param text: the member's name in lower case, as a parameter gives it.
        :param what: what the value is, for the error message (a parameter's name).
        """
        try:
            return cls[str(text).upper()]
        except KeyError:
            raise ValueError(f'{what} must be one of {", ".join(cls.names())}, '
                             f'not {text!r}') from None
