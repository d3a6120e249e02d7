# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""YAML configuration loading with validation messages that name the bad key."""

import itertools
import math
import numbers
import os
import reprlib
import stat
import unicodedata

import yaml

MAX_YAML_BYTES = 1 << 20      # a rig or fabrics file is a few KB; this bounds parse time
MAX_YAML_DEPTH = 32           # the deepest file we ship nests 5 levels
MAX_COORDINATE = 1000.0       # m: a vector beyond this is no character's rig
MAX_ITEMS = 256               # entries of one list of a rig (colliders, regions, sleeves)
_SHOW = reprlib.Repr()
_SHOW.maxstring = _SHOW.maxother = 60
_SHOW.maxlevel = 2
_SHOWN_ITEMS = 8              # of a list shown in an error line
# Unicode's control and format characters, and the line and paragraph separators.
_CONTROL = frozenset({'Cc', 'Cf', 'Zl', 'Zp'})


def shown(value: object) -> str:
    """Return a bounded repr for error lines, whatever the value's size.

    :param value: the value shown.
    """
    return _SHOW.repr(value)


def written(value: object) -> str:
    """Return ``value`` as a user writes it in a params file or ``-p`` (YAML), bounded.

    ``[1000000000.0, 0.0, 0.0]`` for rclpy's ``array('d', [1e9, 0.0, 0.0])``, ``true`` for
    True; strings quoted and cut as :func:`shown` cuts them.

    :param value: the value shown.
    """
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return shown(value)
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        return repr(float(value))
    try:
        items = list(itertools.islice(iter(value), _SHOWN_ITEMS + 1))
    except TypeError:
        return shown(value)
    more = ', ...' if len(items) > _SHOWN_ITEMS else ''
    return f'[{", ".join(written(v) for v in items[:_SHOWN_ITEMS])}{more}]'


def control_character(text: str) -> str:
    """Return the first control or format character of ``text`` as ``U+XXXX at N`` ('' if none).

    Those (a newline, an escape, U+202E that turns the rest of a line around) make a path or a
    frame id read as another in a log line, a terminal or a viewer.

    :param text: a name or a path.
    """
    for k, ch in enumerate(text):
        if unicodedata.category(ch) in _CONTROL:
            return f'U+{ord(ch):04X} at {k}'
    return ''


class DuplicateKey(yaml.YAMLError):
    """A key given twice in one mapping: a YAML reader keeps the last, so one is silently lost.

    :param key: the key.
    :param line: the line (from 1) of its second occurrence.
    :param first: the line of its first.
    """

    def __init__(self, key: object, line: int, first: int):
        super().__init__(f'line {line}: {shown(key)} is given twice (first at line {first}), '
                         'and a YAML reader keeps only the last')
        self.key, self.line, self.first = key, line, first


class _BoundedLoader(yaml.SafeLoader):
    """SafeLoader that refuses aliases, deep nesting and a key given twice in one mapping.

    So no file expands beyond its size, and none says two things of which one is dropped (a
    rig ending in a second ``colliders: []`` ran with no colliders).
    """

    _depth = 0

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = {}
            for key_node, _ in node.value:
                if key_node.tag == 'tag:yaml.org,2002:merge':
                    continue                # ``<<``: its keys may be overridden by design
                key = self.construct_object(key_node, deep=True)
                line = key_node.start_mark.line + 1
                try:
                    if key in seen:
                        raise DuplicateKey(key, line, seen[key])
                except TypeError:
                    continue                # unhashable: SafeLoader says so itself
                seen[key] = line
        return super().construct_mapping(node, deep)

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            raise yaml.composer.ComposerError(None, None, 'aliases (*name) are not accepted',
                                              self.peek_event().start_mark)
        if self._depth >= MAX_YAML_DEPTH:
            raise yaml.composer.ComposerError(None, None, f'nested deeper than {MAX_YAML_DEPTH} '
                                              'levels', self.peek_event().start_mark)
        self._depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def bounded_load(text: str) -> object:
    """Load YAML as yaml.safe_load does, bounded: size, no aliases, no deep nesting.

    At most MAX_YAML_BYTES; every refusal is a yaml.YAMLError.

    :param text: the YAML text.
    """
    if len(text) > MAX_YAML_BYTES:
        raise yaml.YAMLError(f'larger than {MAX_YAML_BYTES} bytes')
    loader = _BoundedLoader(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


class ConfigError(ValueError):
    """A configuration file or value is wrong; the message names the file and key."""


class MissingLink(ConfigError):
    """A rig or set-up names a link the URDF lacks: it is another skeleton's."""


def config_dir() -> str:
    """Return the shipped config folder: the installed share/ folder, else the source tree's."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    here = os.path.join(os.path.dirname(package), 'config')     # a source checkout
    if os.path.isfile(os.path.join(here, 'jacket_rig.yaml')):
        return here
    try:
        from ament_index_python.packages import get_package_share_directory
        return os.path.join(get_package_share_directory('jacket_cloth_ros'), 'config')
    except Exception:  # noqa: BLE001 - no ament index: fall through to the clear error below
        pass
    raise ConfigError('cannot find the jacket_cloth_ros config folder')


_KINDS = ((stat.S_ISFIFO, 'a FIFO'), (stat.S_ISDIR, 'a folder'), (stat.S_ISCHR, 'a device'),
          (stat.S_ISBLK, 'a device'), (stat.S_ISSOCK, 'a socket'))


def regular_file_or_refuse(path: str | os.PathLike, what: str = '',
                           must_exist: bool = True) -> None:
    """Raise ConfigError unless ``path`` is a regular file (or a link to one), never opening it.

    A FIFO blocks its opener until a peer comes, a device or a folder never reads as a file:
    only os.stat looks at them.

    :param path: the file.
    :param what: what the file is (e.g. 'rig'), starting the one-line message.
    :param must_exist: False for an output about to be made: a missing path is fine.
    """
    where = f'{what} {os.fspath(path)}' if what else os.fspath(path)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError as e:
        if not must_exist:
            return
        raise ConfigError(f'{where}: cannot read ({e.strerror})') from None
    except OSError as e:
        raise ConfigError(f'{where}: cannot read ({e.strerror})') from None
    if not stat.S_ISREG(mode):
        kind = next((name for test, name in _KINDS if test(mode)), 'not a plain file')
        raise ConfigError(f'{where}: {kind}, not a regular file')


def shipped(name: str) -> str:
    """Return the path of a file of the shipped config folder.

    :param name: the file's name there (``jacket_rig.yaml``).
    """
    return os.path.join(config_dir(), name)


def parse_yaml(text: str, where: str) -> dict:
    """YAML text (e.g. carried in a recording) to a mapping, with load_yaml's errors.

    :param text: the YAML text.
    :param where: what the text is, as errors name it.
    """
    try:
        data = bounded_load(text)
    except DuplicateKey as e:
        raise ConfigError(f'{where}: {e}') from None
    except yaml.YAMLError as e:
        raise ConfigError(f'{where}: not valid YAML ({_one_line(e)})') from None
    if not isinstance(data, dict):
        raise ConfigError(f'{where}: expected a mapping at the top level')
    return data


def read_text(path: str, what: str) -> str:
    """Read a configuration file's text; errors name the file (``what``: 'URDF', 'rig', ...).

    :param path: the file.
    :param what: what kind of file, as errors name it.
    """
    regular_file_or_refuse(path, what)
    try:
        with open(path, encoding='utf-8') as f:
            return f.read()
    except OSError as e:
        raise ConfigError(f'{what} {path}: cannot read ({e.strerror})') from None
    except UnicodeDecodeError as e:
        raise ConfigError(f'{what} {path}: not a UTF-8 text file (byte {e.start})') from None


def load_yaml(path: str) -> dict:
    """Read a YAML file's top-level mapping, bounded as ``bounded_load``; errors name the file.

    :param path: the YAML file.
    """
    regular_file_or_refuse(path)
    try:
        with open(path, encoding='utf-8') as f:
            data = bounded_load(f.read(MAX_YAML_BYTES + 1))
    except OSError as e:
        raise ConfigError(f'{path}: cannot read ({e.strerror})') from None
    except UnicodeDecodeError as e:
        raise ConfigError(f'{path}: not a UTF-8 text file (byte {e.start})') from None
    except DuplicateKey as e:
        raise ConfigError(f'{path}: {e}') from None
    except yaml.YAMLError as e:
        raise ConfigError(f'{path}: not valid YAML ({_one_line(e)})') from None
    if not isinstance(data, dict):
        raise ConfigError(f'{path}: expected a mapping at the top level')
    return data


def _one_line(error):
    return ' '.join(str(error).split())


class Section:
    """Typed access to one mapping of a config file; every error names file and key path.

    A getter with no ``default`` refuses a missing key. Every key read is marked used, for
    ``reject_unknown``.

    :param data: the mapping.
    :param where: its file and key path, as errors name it.
    """

    def __init__(self, data: object, where: str):
        if not isinstance(data, dict):
            raise ConfigError(f'{where}: expected a mapping')
        self._data = data
        self._where = where
        self._used = set()

    def _path(self, key):
        return f'{self._where}.{key}'

    def has(self, key: str) -> bool:
        """Tell whether the mapping holds ``key`` (without marking it used).

        :param key: the key.
        """
        return key in self._data

    def section(self, key: str, default: dict | None = None) -> 'Section':
        """Return the mapping under ``key`` as a Section.

        :param key: the key.
        :param default: the mapping when the key is missing; None: it must be there.
        """
        self._used.add(key)
        if key not in self._data:
            if default is None:
                raise ConfigError(f'{self._path(key)}: missing')
            return Section(default, self._path(key))
        return Section(self._data[key], self._path(key))

    def sections(self, key: str) -> list['Section']:
        """Return the list of mappings under ``key`` (at most MAX_ITEMS), each as a Section.

        :param key: the key; missing: an empty list.
        """
        self._used.add(key)
        items = self._data.get(key, [])
        if not isinstance(items, list):
            raise ConfigError(f'{self._path(key)}: expected a list')
        if len(items) > MAX_ITEMS:
            raise ConfigError(f'{self._path(key)}: {len(items)} entries, at most {MAX_ITEMS}')
        return [Section(item, f'{self._path(key)}[{i}]') for i, item in enumerate(items)]

    def number(self, key: str, default: float | None = None, lo: float | None = None,
               hi: float | None = None) -> float:
        """Return the finite number under ``key``.

        :param key: the key.
        :param default: the value when the key is missing; None: it must be there.
        :param lo: the least value accepted; None: no bound.
        :param hi: the greatest value accepted; None: no bound.
        """
        self._used.add(key)
        v = self._data.get(key, default)
        if v is None:
            raise ConfigError(f'{self._path(key)}: missing')
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ConfigError(f'{self._path(key)}: expected a number, got {shown(v)}')
        if not math.isfinite(v):
            raise ConfigError(f'{self._path(key)}: {v} is not a finite number')
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            raise ConfigError(f'{self._path(key)}: {v} is outside [{lo}, {hi}]')
        return float(v)

    def integer(self, key: str, default: int | None = None, lo: int | None = None,
                hi: int | None = None) -> int:
        """Return the whole number under ``key``.

        :param key: the key.
        :param default: the value when the key is missing; None: it must be there.
        :param lo: the least value accepted; None: no bound.
        :param hi: the greatest value accepted; None: no bound.
        """
        v = self.number(key, default, lo, hi)
        if v != int(v):
            raise ConfigError(f'{self._path(key)}: expected a whole number, got {v}')
        return int(v)

    def vector(self, key: str, n: int = 3, default: list[float] | None = None,
               lo: float = -MAX_COORDINATE, hi: float = MAX_COORDINATE) -> list[float]:
        """Return a list of ``n`` finite numbers, each in [lo, hi].

        :param key: the key.
        :param n: how many numbers.
        :param default: the list when the key is missing; None: it must be there.
        :param lo: the least value accepted of each.
        :param hi: the greatest value accepted of each.
        """
        self._used.add(key)
        v = self._data.get(key, default)
        ok = isinstance(v, (list, tuple)) and len(v) == n and all(
            isinstance(e, (int, float)) and not isinstance(e, bool) for e in v)
        if not ok:
            raise ConfigError(f'{self._path(key)}: expected a list of {n} numbers, '
                              f'got {shown(v)}')
        if not all(math.isfinite(e) for e in v):
            raise ConfigError(f'{self._path(key)}: {v} has a number that is not finite')
        if not all(lo <= e <= hi for e in v):
            raise ConfigError(f'{self._path(key)}: {v} has a number outside [{lo}, {hi}]')
        return [float(e) for e in v]

    def text(self, key: str, default: str | None = None,
             choices: tuple[str, ...] | None = None) -> str:
        """Return the non-empty string under ``key``.

        :param key: the key.
        :param default: the value when the key is missing; None: it must be there.
        :param choices: the values accepted; None: any.
        """
        self._used.add(key)
        v = self._data.get(key, default)
        if not isinstance(v, str) or not v:
            raise ConfigError(f'{self._path(key)}: expected a non-empty string, got {shown(v)}')
        if choices is not None and v not in choices:
            raise ConfigError(f'{self._path(key)}: {shown(v)} is not one of {sorted(choices)}')
        return v

    def texts(self, key: str, default: list[str] | None = None) -> list[str]:
        """Return the list of strings under ``key``.

        :param key: the key.
        :param default: the list when the key is missing; None: it must be there.
        """
        self._used.add(key)
        v = self._data.get(key, default)
        if not isinstance(v, list) or not all(isinstance(e, str) for e in v):
            raise ConfigError(f'{self._path(key)}: expected a list of strings, got {shown(v)}')
        return list(v)

    def reject_unknown(self) -> None:
        """Typos should not be silently ignored: name every key nobody read."""
        unknown = sorted(map(str, set(self._data) - self._used))
        if unknown:
            raise ConfigError(f'{self._where}: unknown key(s) {shown(", ".join(unknown))}')
