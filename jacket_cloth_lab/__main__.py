# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``python -m jacket_cloth_lab`` runs the lab's command (bench, bench speed, stress)."""

import sys

from .cli import main

sys.exit(main())
