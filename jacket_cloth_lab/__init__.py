# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The lab: the simulation core measured against references and pushed where methods fail.

It depends on ``jacket_cloth_ros`` and never the other way, so an install can leave it out.
"""

import os

# The DDS domains of the lab's live parts, in that order: a test run gives its own band by
# JACKET_CLOTH_LAB_DOMAIN (test/conftest.py) so concurrent runs do not cross talk.
LAB_PARTS = ('crowd', 'tf_batching', 'profile', 'endurance')


def lab_domain(part: str) -> int:
    """Return the DDS domain a live part of the lab runs in.

    :param part: one of :data:`LAB_PARTS`.
    """
    base = os.environ.get('JACKET_CLOTH_LAB_DOMAIN')
    first = int(base) if base else 224 + 4 * (os.getpid() % 2)     # above the tests' 20-223
    return first + LAB_PARTS.index(part)
