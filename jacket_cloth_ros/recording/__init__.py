# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""MCAP input/output in the ROS 2 profile (ros2msg schemas, CDR messages)."""
