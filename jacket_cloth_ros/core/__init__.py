# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The simulation core: skeleton, rig, cloth, hood and the fixed-step driver. No ROS here."""
