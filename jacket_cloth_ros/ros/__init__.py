# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The ROS 2 adapter: the node and the message building it uses. The physics lives in core."""
