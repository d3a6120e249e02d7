# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The compiled physics (numba), one file per thing simulated, each on the bundles of core.

``pose`` (skeleton, M1/M2 layer, skinning, bone frames) -> ``colliders`` (M10 and the body's
other shapes) -> ``cloth`` (M4-M6, M11-M13, M15) and ``hood`` (M8) -> ``step`` (every fixed
step of one input) -> ``crowd`` (many characters in one call); ``sampling`` turns a
JointState's values into a skeleton sample.
"""
