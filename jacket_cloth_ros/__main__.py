# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``python -m jacket_cloth_ros`` is the ``jacket_cloth`` command, guarded as its entry point is.

Through signals.tools, not the tools' main itself: a Ctrl-C while Python imports numpy and
numba is then one line and 130, not a KeyboardInterrupt traceback.
"""

import sys

from .signals import tools

sys.exit(tools())
