# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A picture of a rig at rest, before any run: front and side in a Z-up world view.

The skeleton, the cloth grid, the colliders (outlines), the hood and the M1/M2 jacket bones at
the URDF's zero pose, turned so that the character's up is the picture's up and its forward the
side view's right, whatever the root link's axes.
"""

from typing import TYPE_CHECKING

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .propose import virtual_links  # noqa: E402

if TYPE_CHECKING:           # for the annotations only
    from ..core.rig import Rig

CLOTH = (0.45, 0.35, 0.25)
BONES = (0.15, 0.1, 0.35)
HOOD = (0.75, 0.3, 0.1)
BODY = (0.2, 0.45, 0.75)


def _ellipse(center, axes, view):
    """Outline of an ellipsoid (centre, 3x3 axes scaled by the radii) seen along a view."""
    p = view
    m = p @ axes
    cov = m @ m.T
    w, v = np.linalg.eigh(cov)
    t = np.linspace(0, 2 * np.pi, 60)
    circle = np.stack([np.cos(t), np.sin(t)])
    return (p @ center)[:, None] + v @ (np.sqrt(np.maximum(w, 0))[:, None] * circle)


def draw_rig(rig: 'Rig', up: np.ndarray, forward: np.ndarray, png_path: str,
             title: str = '') -> None:
    """Draw the rig's front and side views at rest into a PNG.

    :param rig: the loaded rig.
    :param up: the character's up direction, in its root frame.
    :param forward: the direction it faces, in its root frame (its part along ``up`` ignored).
    :param png_path: the PNG written.
    :param title: the figure's title; empty: none.
    """
    sk = rig.skeleton
    links = sk.forward(np.zeros(len(sk.joint_names)))
    virtual = set(virtual_links(sk))
    up = np.asarray(up, float) / np.linalg.norm(up)
    fwd = np.asarray(forward, float) - (np.asarray(forward, float) @ up) * up
    fwd /= np.linalg.norm(fwd)
    left = np.cross(up, fwd)
    views = (('front', np.stack([-left, up]), 'y (m, the character\'s right <- -> left)'),
             ('side', np.stack([fwd, up]), 'x (m, forward)'))
    fig, axes = plt.subplots(1, 2, figsize=(9, 7))
    layer = rig.layer.solve(links) if rig.layer is not None else None
    cloth = rig.rest.reshape(rig.rows, rig.cols, 3)
    for ax, (name, view, xlabel) in zip(axes, views):
        def p2(q):
            return np.asarray(q) @ view.T
        for i in range(1, len(links)):
            seg = p2(links[[sk.parent[i], i], :3, 3])
            if i in virtual:                # a sensor frame: shown, but not as a bone
                ax.plot(seg[:, 0], seg[:, 1], color='0.6', lw=0.8, ls=':')
                continue
            ax.plot(seg[:, 0], seg[:, 1], color='0.25', lw=2.2, solid_capstyle='round')
        for link, center, rot, radii in zip(rig.collider_links, rig.collider_centers,
                                            rig.collider_rotations, rig.collider_radii):
            T = links[link]
            outline = _ellipse(T[:3, :3] @ center + T[:3, 3], T[:3, :3] @ rot * radii, view)
            ax.fill(outline[0], outline[1], color=BODY, alpha=0.18, lw=0.8, ec=BODY)
        for link, ends, radius in zip(rig.capsule_links, rig.capsule_ends, rig.capsule_radii):
            T = links[link]
            a, b = (T[:3, :3] @ ends.T).T + T[:3, 3]
            for t in np.linspace(0, 1, 7):
                c = p2(a + t * (b - a))
                ax.add_patch(plt.Circle(c, radius, color=BODY, alpha=0.08, lw=0))
            ab = p2(np.stack([a, b]))
            ax.plot(ab[:, 0], ab[:, 1], color=BODY, lw=0.8, ls=':')
        for r in range(rig.rows):
            row = p2(cloth[r])
            ax.plot(row[:, 0], row[:, 1], color=CLOTH, lw=0.8)
        for c in range(rig.cols):
            col = p2(cloth[:, c])
            ax.plot(col[:, 0], col[:, 1], color=CLOTH, lw=0.8)
        if layer is not None:
            for a, b in zip(layer.positions, layer.tips):
                seg = p2(np.stack([a, b]))
                ax.plot(seg[:, 0], seg[:, 1], color=BONES, lw=2.2)
        h = links[rig.hood.link]
        anchor = h[:3, :3] @ rig.hood.pivot + h[:3, 3]
        tip = anchor + h[:3, :3] @ rig.hood.rest_direction * rig.hood.length
        seg = p2(np.stack([anchor, tip]))
        ax.plot(seg[:, 0], seg[:, 1], color=HOOD, lw=3)
        ax.plot(seg[1, 0], seg[1, 1], 'o', color=HOOD, ms=7)
        ax.set_aspect('equal')
        ax.grid(alpha=0.3)
        ax.set_xlabel(xlabel, fontsize=8)
        ax.set_ylabel('z (m, up)', fontsize=8)
        ax.set_title(f'{name} view', fontsize=10)
        ax.tick_params(labelsize=7)
    fig.suptitle(title or 'rig at rest: skeleton (grey), cloth grid (brown), colliders (blue), '
                 'hood (orange), jacket bones (navy)', fontsize=10)
    fig.tight_layout()
    fig.savefig(png_path, dpi=100)
    plt.close(fig)
