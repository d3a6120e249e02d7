# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""What a write that found no room looks like: shared by the MCAP writer, the recorder, the node.

Kept apart from mcap_file so the node can tell a full disk without importing mcap.
"""

import errno

# A write that fails for these found no room: the file is rolled back to its last whole record
# and what did not fit is kept for finish(), which writes as much of it as the room allows.
NO_ROOM = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


def no_room(error: BaseException) -> bool:
    """Tell whether ``error`` is a write that found the disk (or the quota) full.

    :param error: the exception a write raised.
    :returns: True for ENOSPC, EDQUOT and EFBIG.
    """
    return isinstance(error, OSError) and error.errno in NO_ROOM
