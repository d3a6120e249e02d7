# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Checks that CDR bytes hold a whole message before rclpy decodes them.

Why: rclpy's ``deserialize_message`` (Fast CDR) decodes a 4-byte ``00 01 01 01`` as a whole
Vector3Stamped, from memory past the end (different values each run): the encapsulation
options' padding count shortens the buffer's end below its start. A fuzzed ~/wind like that
ended a CI run with a segmentation fault. Walking the message's layout from its rosidl type
description, the padding included, costs a few microseconds and rejects such bytes first.
"""

import functools
import importlib
import struct

from rosidl_parser import definition as rosidl

_SIZES = {'boolean': 1, 'octet': 1, 'char': 1, 'int8': 1, 'uint8': 1,
          'int16': 2, 'uint16': 2, 'wchar': 2, 'int32': 4, 'uint32': 4, 'float': 4,
          'int64': 8, 'uint64': 8, 'double': 8}


def check_whole(raw: bytes, msg_type: type) -> None:
    """Raise ValueError unless ``raw`` is CDR long enough for every field of ``msg_type``.

    :param raw: the serialized message.
    :param msg_type: the message class expected.
    """
    if len(raw) < 4 or raw[0] != 0 or raw[1] not in (0, 1):
        raise ValueError('not a CDR message')
    walker = _Walker(raw, '<' if raw[1] == 1 else '>')
    walker.message(msg_type)
    padding = raw[3] & 0x03             # the options' count of padding bytes at the end
    if walker.at + padding > len(raw):
        raise ValueError(f'cut short ({len(raw)} bytes, {padding} of them padding)')


class _Walker:
    def __init__(self, raw, endian):
        self.raw, self.u32, self.at = raw, struct.Struct(endian + 'I'), 4

    def take(self, size, align):
        self.at += -(self.at - 4) % align
        if self.at + size > len(self.raw):
            raise ValueError(f'cut short ({len(self.raw)} bytes)')
        self.at += size

    def count(self):
        self.take(4, 4)
        (n,) = self.u32.unpack_from(self.raw, self.at - 4)
        if n > len(self.raw):
            raise ValueError(f'a length of {n} in a message of {len(self.raw)} bytes')
        return n

    def message(self, msg_type):
        for slot in msg_type.SLOT_TYPES:
            self.field(slot)

    def field(self, slot):
        if isinstance(slot, rosidl.BasicType):
            size = _SIZES.get(slot.typename)
            if size is None:
                raise ValueError(f'unsupported CDR type {slot.typename}')
            self.take(size, size)
        elif isinstance(slot, rosidl.AbstractString):
            self.take(self.count(), 1)
        elif isinstance(slot, rosidl.NamespacedType):
            self.message(_message_class(tuple(slot.namespaces), slot.name))
        elif isinstance(slot, rosidl.AbstractNestedType):
            n = slot.size if isinstance(slot, rosidl.Array) else self.count()
            item = slot.value_type
            if isinstance(item, rosidl.BasicType) and item.typename in _SIZES:
                if n:
                    size = _SIZES[item.typename]
                    self.take(n * size, size)
            else:
                for _ in range(n):
                    self.field(item)
        else:
            raise ValueError(f'unsupported CDR field {slot!r}')


@functools.cache
def _message_class(namespaces, name):
    return getattr(importlib.import_module('.'.join(namespaces)), name)
