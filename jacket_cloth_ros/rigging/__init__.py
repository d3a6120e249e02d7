# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A rig proposed for any skeleton (``jacket_cloth rig``), and its picture."""
