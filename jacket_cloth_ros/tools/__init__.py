# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The ``jacket_cloth`` command line: motion source, demo, pictures."""
