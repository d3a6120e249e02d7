# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""M16: fabric presets, parameter sets of the one cloth system."""

from dataclasses import dataclass, fields, replace

from .config import ConfigError, Section, shown, load_yaml, shipped


DEFAULT_MAX_HORIZONTAL_STRETCH = 0.05


@dataclass(frozen=True)
class Fabric:
    damping: float             # M4: share of velocity lost per step
    stretch_stiffness: float   # M5: stretch group
    shear_bend_stiffness: float  # M5: shear/bend group
    iterations: int            # Gauss-Seidel sweeps per step
    world_share: float         # M14: share of world motion felt by the cloth
    wind_scale: float
    contact_damping: float     # M15: extra damping of vertices touching a collider
    edge_damping: float        # M13: edge vertices' own parameters
    edge_world_share: float
    edge_wind_scale: float
    edge_max_distance_scale: float
    hood_damping: float
    # Most stretch of a horizontal edge over its rest length after each step (a strain limit;
    # optional in a fabric file).
    max_horizontal_stretch: float = DEFAULT_MAX_HORIZONTAL_STRETCH

    def with_values(self, **changes: float) -> 'Fabric':
        """Return a copy of the preset with some values changed.

        :param changes: the new values by field name.
        """
        return replace(self, **changes)


FABRIC_RANGES = {
    'damping': (0.0, 0.99), 'stretch_stiffness': (0.0, 1.0), 'shear_bend_stiffness': (0.0, 1.0),
    'iterations': (1, 100), 'world_share': (0.0, 1.0), 'wind_scale': (0.0, 10.0),
    'contact_damping': (0.0, 0.99), 'edge_damping': (0.0, 0.99), 'edge_world_share': (0.0, 1.0),
    'edge_wind_scale': (0.0, 10.0), 'edge_max_distance_scale': (0.1, 5.0),
    'hood_damping': (0.0, 0.99), 'max_horizontal_stretch': (0.0, 10.0),
}
OPTIONAL = {'max_horizontal_stretch': DEFAULT_MAX_HORIZONTAL_STRETCH}


def load_fabrics(path: str | None = None) -> dict[str, Fabric]:
    """All presets of a fabrics YAML file, validated; {name: Fabric}.

    :param path: the fabrics YAML file; None: the shipped ``fabrics.yaml``.
    """
    path = path or shipped('fabrics.yaml')
    return fabrics_from_data(load_yaml(path), path)


def fabrics_from_data(data: dict, path: str) -> dict[str, Fabric]:
    """Presets from parsed YAML; ``path`` names where they came from in error messages.

    :param data: the parsed YAML, {name: {field: value}}.
    :param path: where the data came from, named in error messages.
    """
    out = {}
    for name in data:
        sec = Section(data[name], f'{path}: {shown(name)}')
        values = {}
        for f in fields(Fabric):
            lo, hi = FABRIC_RANGES[f.name]
            if f.name == 'iterations':
                values[f.name] = sec.integer(f.name, lo=lo, hi=hi)
            else:
                values[f.name] = sec.number(f.name, OPTIONAL.get(f.name), lo=lo, hi=hi)
        sec.reject_unknown()
        out[name] = Fabric(**values)
    return out


def load_fabric(name: str, path: str | None = None) -> Fabric:
    """Return one preset of a fabrics YAML file, validated.

    :param name: the preset's name.
    :param path: the fabrics YAML file; None: the shipped ``fabrics.yaml``.
    """
    presets = load_fabrics(path)
    if name not in presets:
        raise ConfigError(f'fabric {name!r} is not a preset (presets: {", ".join(presets)})')
    return presets[name]
