# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Jacket and hood secondary motion for ROS 2 (the Alan Wake cloth method).

Layout: ``core`` is the simulation (numpy/numba, no ROS); ``ros`` the node; ``recording`` the
MCAP input/output; ``motion`` the built-in clips; ``tools`` the ``jacket_cloth`` command.
"""
