# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``python -m jacket_cloth_ros`` is the ``jacket_cloth`` command."""

import sys

from .tools.cli import main

sys.exit(main())
