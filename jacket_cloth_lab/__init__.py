# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The lab: the simulation core measured against references and pushed where methods fail.

It depends on ``jacket_cloth_ros`` and never the other way, so an install can leave it out.
"""
