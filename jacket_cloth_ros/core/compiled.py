# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""How the package's kernels are compiled: ``njit`` with one stamp, ``borrowed``, FixedTypes.

numba marks a cached function with the hash of its own file only. Our kernels call each other
across files (physics.step.advance compiles physics.cloth.cloth_step into itself), so after an
edit of cloth.py the cached ``advance`` went on running the old cloth step: seen here, a
replay's /tf differed in the last bits from a fresh build of the same source. Here each of the
package's kernels is marked with the hashes of every file that holds kernels (any file of the
package that compiles with ``@njit``), of ``bundles.py``, whose field order they read, and of
this file, whose ``borrowed`` they compile in, so an edit to any of them recompiles them all.
The kernel modules take ``njit`` from here, so the marks are in place before their first
``@njit(cache=True)``.

``borrowed`` spares the steps numba's atomic reference counts on the arrays of their bundles;
FixedTypes spares a kernel called from Python the typing of its arguments at every call.
"""

import functools
import hashlib
import os
from typing import TYPE_CHECKING

from numba import njit, typeof, types
from numba.core import caching, cgutils
from numba.core.typing.typeof import Purpose
from numba.extending import intrinsic
from numba.np.arrayobj import make_array

if TYPE_CHECKING:           # for the annotations only
    from numba.core.dispatcher import Dispatcher

__all__ = ['njit', 'borrowed', 'kernel_files', 'kernels_stamp', 'FixedTypes']

# Set (the tests set it) to type every call again and fail on a type that changed.
CHECK_TYPES = os.environ.get('JACKET_CLOTH_CHECK_TYPES', '') not in ('', '0')

_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Read, not listed: a kernel file is any of the package's files that compiles with this njit.
_KERNEL_MARK = b'@njit'
_BUNDLES = os.path.join(_PACKAGE, 'core', 'bundles.py')
_THIS = os.path.abspath(__file__)


@functools.lru_cache(maxsize=None)
def kernel_files() -> tuple[str, ...]:
    """Return every file of the package holding a kernel, bundles.py and this one, sorted."""
    found = {_BUNDLES, _THIS}
    for folder, _, names in os.walk(_PACKAGE):
        for name in names:
            path = os.path.join(folder, name)
            if name.endswith('.py'):
                with open(path, 'rb') as f:
                    if _KERNEL_MARK in f.read():
                        found.add(path)
    return tuple(sorted(found))


@functools.lru_cache(maxsize=None)
def _content_hash(path, mtime, size):        # read again only when the file changes
    with open(path, 'rb') as f:
        return hashlib.sha256(f.read()).digest()


def kernels_stamp() -> tuple[bytes, ...]:
    """Return the content hashes of every file holding one of the package's kernels."""
    stamps = []
    for path in kernel_files():
        st = os.stat(path)
        stamps.append(_content_hash(path, st.st_mtime, st.st_size))
    return tuple(stamps)


class _PackageStamp:
    """For the package's own files: the stamp of all kernel files, not of one."""

    @classmethod
    def from_function(cls, py_func, py_file):
        if os.path.abspath(py_file) not in kernel_files():
            return None
        return super().from_function(py_func, py_file)

    def get_source_stamp(self):
        return kernels_stamp()


def _numba_locator(name):
    """Return numba's cache locator class ``name``: public from numba 0.62, ``_name`` before."""
    return getattr(caching, name, None) or getattr(caching, '_' + name)


class PackageUserDirLocator(_PackageStamp, _numba_locator('UserProvidedCacheLocator')):
    """NUMBA_CACHE_DIR set: there, as numba would."""


class PackageInTreeLocator(_PackageStamp, _numba_locator('InTreeCacheLocator')):
    """Else in the package's __pycache__, as numba would."""


class PackageUserWideLocator(_PackageStamp, _numba_locator('UserWideCacheLocator')):
    """Else (an install that cannot be written) in the user's cache folder, as numba would."""


_LOCATORS = caching.CacheImpl._locator_classes
for _locator in (PackageUserWideLocator, PackageInTreeLocator, PackageUserDirLocator):
    if _locator not in _LOCATORS:           # ends in numba's order, before numba's own
        _LOCATORS.insert(0, _locator)


class FixedTypes:
    """A compiled kernel called with arguments whose types never change, typed once.

    numba types every argument of every call; for named tuples it does so in Python, which
    costs more than the call itself. Here the first call goes through numba's dispatcher
    (compiling or loading, and checking the types), and later calls go straight to the
    entry point compiled for those types, which reads any argument as the type it had then:
    every caller builds its arguments with the bundles' builders, which fix each dtype and
    layout (physics.crowd.load_motion also takes InputParser's Samples, C float64 arrays it
    makes itself; another layout would be misread, which the tests' type check catches).
    ``JACKET_CLOTH_CHECK_TYPES=1`` (set by the tests) checks every call.

    :param dispatcher: the numba dispatcher of the kernel.
    :param check: whether every call checks its argument types; None: as JACKET_CLOTH_CHECK_TYPES
        says, False never (for timing).
    """

    def __init__(self, dispatcher: 'Dispatcher', check: bool | None = None):
        self.dispatcher = dispatcher
        self._check = CHECK_TYPES if check is None else check
        self._entry = None
        self._types = None
        # The entry point once typed, for a hot path that calls it with no Python frame of
        # ours between (``(kernel.entry or kernel)(...)``); None while every call is checked.
        self.entry = None

    def __call__(self, *args: object) -> object:
        """Call the kernel; the first call through numba's dispatcher, later ones straight in.

        :param args: the kernel's arguments, typed as in the first call.
        :returns: what the kernel returns.
        """
        if self._entry is not None:
            if self._check:
                types = tuple(typeof(a, Purpose.argument) for a in args)
                if types != self._types:
                    raise TypeError(f'{self.dispatcher.__name__}: argument types changed '
                                    f'from {self._types} to {types}')
            return self._entry(*args)
        result = self.dispatcher(*args)
        types = tuple(typeof(a, Purpose.argument) for a in args)
        overload = self.dispatcher.overloads.get(types)
        if overload is not None:           # else numba converted an argument: keep typing
            self._entry, self._types = overload.entry_point, types
            if not self._check:
                self.entry = self._entry
        return result


def _unowned(context, builder, ty, value):
    """Return ``value`` of type ``ty`` with every array in it holding no reference."""
    if isinstance(ty, types.Array):
        array = make_array(ty)(context, builder, value=value)
        array.meminfo = cgutils.get_null_value(array.meminfo.type)
        array.parent = cgutils.get_null_value(array.parent.type)
        return array._getvalue()
    if isinstance(ty, types.BaseTuple):
        for i, member in enumerate(ty.types):
            value = builder.insert_value(
                value, _unowned(context, builder, member, builder.extract_value(value, i)), i)
    return value


@intrinsic
def borrowed(typingctx: object, value: types.Type) -> tuple:
    """Return a bundle whose arrays count no references: for a call that outlives none of them.

    Compiled code calls ``borrowed(bundle)``: a bundle (a tuple, nested or not) with the same
    arrays and values. numba counts a reference, atomically, for every array of every bundle
    each compiled function is handed, in and out; an array that holds no reference (as one
    unboxed with numba's reference counting off) is skipped at a null test. Only for arrays
    their owner keeps alive for the whole call, never returned, and stored only where their
    owner outlives the store (physics.crowd.borrowed_list: a typed list with a Python mirror,
    never read from Python, where numba would box an array that owns nothing).

    :param typingctx: numba's typing context (numba passes it).
    :param value: the bundle's type.
    :returns: the signature and the code that makes the borrowed bundle, as numba's
        intrinsics do.
    """
    def codegen(context, builder, signature, args):
        return _unowned(context, builder, signature.args[0], args[0])
    return value(value), codegen
