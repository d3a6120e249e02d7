# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Where the tools write: regular files only, never an input, none overwritten without ``--force``.

A file is replaced only by a complete new one. Every tool that writes a file checks it here
first (replay -o, motion -o, picture -o, the files of analyze --out, the demo's), so a
device, a folder or the recording being read is refused in one line before anything is
read or written.
"""

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Sequence

from ..recording.writer import is_bag_folder

# The process's umask, for giving a finished output the mode a plain open() would have.
_UMASK = os.umask(0o022)
os.umask(_UMASK)


class OutputError(ValueError):
    """An output path a tool refuses; the message is one line."""


def check_output(path: str | os.PathLike, force: bool, inputs: Iterable[str | None] = (),
                 recording: bool = False) -> None:
    """Refuse ``path`` as an output file unless it is safe to write.

    Its folder exists, it is none of ``inputs`` and, if it exists, it is a regular file and
    ``force`` is set.

    :param path: the output file.
    :param force: whether an existing file may be overwritten.
    :param inputs: the run's input files, or bag folders it must not be inside; None skipped.
    :param recording: whether the output is a recording: one not ending in ``.mcap`` is a bag
        folder (writer.is_bag_folder), which if it exists must be a bag (with metadata.yaml).
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise OutputError(f'folder {folder} does not exist')
    _not_an_input(path, inputs)
    if recording and is_bag_folder(path) and os.path.lexists(path):
        if os.path.islink(path) or not os.path.isfile(os.path.join(path, 'metadata.yaml')):
            raise OutputError(f'{path} is not a regular file nor a bag folder (a device, pipe, '
                              'link or plain folder); recordings are .mcap files or bag folders')
        if not force:
            raise OutputError(f'{path} exists (use --force to overwrite)')
    elif os.path.lexists(path):
        if not os.path.isfile(path):
            raise OutputError(f'{path} is not a regular file (a device, folder, pipe or broken '
                              'link); outputs are regular files')
        if not force:
            raise OutputError(f'{path} exists (use --force to overwrite)')


def check_picture(path: str | os.PathLike) -> None:
    """Refuse a picture's path unless its extension names a format matplotlib writes.

    Checked before anything is written: the format is known only from the name, and a tool
    that found out at the save had already put its other outputs in place.

    :param path: the picture file.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    ext = os.path.splitext(os.fspath(path))[1].lower().lstrip('.')
    formats = FigureCanvasAgg.get_supported_filetypes()
    if ext not in formats:
        said = f'.{ext} is not a picture format' if ext else 'no extension names its format'
        # The common ones this matplotlib writes (an older one writes no GIF).
        named = ', '.join(f'.{f}' for f in ('png', 'jpg', 'svg', 'pdf', 'gif') if f in formats)
        raise OutputError(f'{path}: {said}; end the name in {named} or another format '
                          'matplotlib writes')


def same_name(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Tell whether two paths name one file, or would on a file system blind to case.

    :param a: one path.
    :param b: the other.
    """
    return (os.path.normcase(os.path.abspath(a)).lower()
            == os.path.normcase(os.path.abspath(b)).lower())


def check_output_folder(folder: str | os.PathLike, names: Iterable[str], force: bool,
                        inputs: Iterable[str | None] = ()) -> None:
    """Run ``check_output`` for each of the files ``names`` a tool writes into ``folder``.

    The folder is made if missing; if it exists, it must be one.

    :param folder: the output folder.
    :param names: the file names written into it.
    :param force: whether existing files may be overwritten.
    :param inputs: the run's input files or bag folders; None skipped.
    """
    folder = os.fspath(folder)
    if os.path.lexists(folder) and not os.path.isdir(folder):
        raise OutputError(f'{folder} is not a folder')
    _not_an_input(folder, inputs)
    if not os.path.isdir(folder):
        return            # made by the tool: nothing in it to overwrite
    for name in names:
        check_output(os.path.join(folder, name), force, inputs)


def _not_an_input(path, inputs):
    real = os.path.realpath(path)
    for given in inputs:
        if not given or not os.path.exists(given):
            continue
        given = os.fspath(given)
        if os.path.isdir(given) and real.startswith(os.path.join(os.path.realpath(given), '')):
            raise OutputError(f'{path} is inside the input folder {given}; write the output '
                              'elsewhere')
        for one in [given, *_bag_files(given)]:
            if os.path.realpath(one) == real or (os.path.exists(path) and os.path.exists(one)
                                                 and os.path.samefile(path, one)):
                raise OutputError(f'{path} is the input {one}; write the output elsewhere')
            if os.path.realpath(one).startswith(os.path.join(real, '')):
                raise OutputError(f'{path} holds the input {one}; write the output elsewhere')


def _bag_files(given):
    """Return the files a bag folder's recording is read from.

    Its metadata.yaml may reach outside it (``../x.mcap``) or through links.
    """
    if not os.path.isdir(given):
        return []
    from ..recording.reader import RecordingError, mcap_files
    try:
        return mcap_files(given)
    except RecordingError:          # the reader says what is wrong with it, in one line
        return []


@contextlib.contextmanager
def replacing(path: str | os.PathLike, recording: bool = False,
              force: bool = False) -> Iterator[str]:
    """Yield a temporary path next to ``path`` to write the output to.

    It becomes ``path`` only when the block ends without an error, so a failed run leaves the
    old file (or none). Without ``force``, only if nothing is at ``path`` by then: the check
    before the run cannot see a file made during it.

    :param path: the output file.
    :param recording: whether the output is a recording: for a bag folder, the temporary path
        is a folder's, not yet made.
    :param force: whether a file (or bag) at ``path`` is replaced.
    """
    path = os.fspath(path)
    if recording and is_bag_folder(path):
        with _replacing_folder(os.path.normpath(path), force) as tmp:
            yield tmp
        return
    with replacing_all([path], force) as (tmp,):
        yield tmp


@contextlib.contextmanager
def replacing_all(paths: Sequence[str | os.PathLike], force: bool = False) -> Iterator[list]:
    """Yield a temporary path next to each of ``paths``; they become theirs together at the end.

    As :func:`replacing` for a tool that writes several files (a filmstrip and its
    animation, a rig and its picture): placed together at the block's end by
    :func:`place_all`, so a file that fails to be made leaves none of the others behind
    (only a failure between the final renames can leave the first in place).

    :param paths: the output files.
    :param force: whether files at ``paths`` are replaced.
    """
    paths = [os.fspath(p) for p in paths]
    tmps = []
    try:
        for path in paths:
            folder, name = os.path.split(os.path.abspath(path))
            # A fresh name (never an existing file, nor an input), ending as the output does
            # so that writers choosing a format by extension (matplotlib) choose the same.
            fd, tmp = tempfile.mkstemp(prefix=f'.{name}.',
                                       suffix='.partial' + os.path.splitext(name)[1], dir=folder)
            os.close(fd)
            tmps.append(tmp)
        yield tmps
        for tmp in tmps:
            os.chmod(tmp, 0o666 & ~_UMASK)
        place_all('', tmps, paths, force)     # each temporary file's own path: no folder
    finally:
        for tmp in tmps:
            if os.path.exists(tmp):
                os.remove(tmp)


def place_all(folder: str, names: list[str], paths: list[str], force: bool) -> None:
    """Move finished files to their paths, all or (a path taken, without ``force``) none.

    Every name is taken by an exclusive create before any file moves, so a refusal leaves
    no new file beside an old one.

    :param folder: the folder the finished files are in, on the paths' file system ('':
        ``names`` are the files' paths).
    :param names: their names in ``folder``.
    :param paths: where each goes.
    :param force: whether files at those paths are replaced.
    """
    claimed = set()
    try:
        if not force:
            for path in paths:
                try:
                    os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
                except FileExistsError:
                    raise OutputError(f'{path} exists (use --force to overwrite)') from None
                claimed.add(path)
        for name, path in zip(names, paths):
            os.replace(os.path.join(folder, name), path)
            claimed.discard(path)
    finally:
        for path in claimed:            # the empty files that took names, never filled
            os.remove(path)


@contextlib.contextmanager
def _replacing_folder(path, force):
    """Do ``replacing`` for a bag folder: written under a fresh name, then swapped in."""
    parent, name = os.path.split(os.path.abspath(path))
    scratch = tempfile.mkdtemp(prefix=f'.{name}.', suffix='.partial', dir=parent)
    tmp = os.path.join(scratch, name)
    try:
        # With its separator: a bag asked for as ``x.mcap/`` is a folder to its writer too,
        # not a file the rename into a folder then failed on.
        yield os.path.join(tmp, '')
        if force:
            _swap_folder(tmp, path, os.path.join(scratch, name + '.old'))
            return
        try:                # taken by an empty folder of ours, which the rename replaces
            os.mkdir(path)
        except FileExistsError:
            raise OutputError(f'{path} exists (use --force to overwrite)') from None
        try:
            os.rename(tmp, path)
        except BaseException:       # a failure, or a signal: our empty folder goes
            if os.path.isdir(tmp):
                os.rmdir(path)
            raise
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _swap_folder(tmp, path, old):
    """Put the folder ``tmp`` at ``path``; a bag there goes to ``old`` (back, if that fails)."""
    try:
        if os.path.lexists(path):
            os.rename(path, old)
        os.rename(tmp, path)
    except BaseException:       # a failure, or a signal at either rename
        if os.path.lexists(old) and not os.path.lexists(path):
            os.rename(old, path)            # the old bag stays where it was
        raise
