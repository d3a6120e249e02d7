# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A session as an animated GIF: side and front views of every recorded marker frame.

The frames are the filmstrip's (``picture.recorded_frames``: the skinned jacket and body as the
node published them, or with ``debug`` the cloth, hood and jacket bones and the skinned pose),
played at their recorded pace. A long session is thinned to at most ``MAX_FRAMES`` frames,
evenly, so the time and the file stay bounded.
"""

from typing import TYPE_CHECKING

import numpy as np

from .picture import (VIEWS, axis_label, body_link, draw_view, in_view, plt, recorded_frames,
                      view_axes_of, view_limits)

if TYPE_CHECKING:           # for the annotations only
    from ..core.rig import Rig
    from ..core.skeleton import Skeleton

MAX_FRAMES = 600


def render_animation(mcap_path: str, gif_path: str, skeleton: 'Skeleton',
                     rig: 'Rig | None' = None, max_frames: int = MAX_FRAMES,
                     style: str = 'jacket') -> int:
    """Write a recording's marker frames as a GIF; return the frames drawn.

    :param mcap_path: the recording (an MCAP file or a bag folder) with ~/markers in it.
    :param gif_path: the GIF to write.
    :param skeleton: the recorded character.
    :param rig: its rig, for the skinned pose (dashed) and the world's up and forward.
    :param max_frames: at most this many frames, evenly chosen over the session.
    :param style: ``jacket`` (the shaded jacket on the body) or ``debug`` (see draw_view).
    """
    from matplotlib.animation import FuncAnimation, PillowWriter

    def evenly(log_times, t0):
        n = len(log_times)
        return range(n) if n <= max_frames else np.linspace(0, n - 1, max_frames).astype(int)
    frames, t0 = recorded_frames(mcap_path, skeleton, rig, evenly)
    axes_world = view_axes_of(frames, rig)
    centre = body_link(skeleton)
    frames = [in_view(f, axes_world, centre) for f in frames]
    across, upward = view_limits(frames)
    labels = (axis_label(axes_world[:, 0], 'forward'), axis_label(axes_world[:, 1], 'left'))
    fig, axes = plt.subplots(1, 2, figsize=(6.4, 4.6))
    spans = np.diff([f.stamp_ns for f in frames]) * 1e-9
    fps = 1.0 / float(np.median(spans)) if len(spans) and np.median(spans) > 0 else 10.0

    def draw(k):
        f = frames[k]
        for ax, (view, axis) in zip(axes, VIEWS):
            ax.cla()
            draw_view(ax, f, skeleton, axis, across, upward, style)
            ax.set_xlabel(labels[axis], fontsize=8)
            ax.set_title(f'{view} view', fontsize=9)
        fig.suptitle(f't = {(frames[k].stamp_ns - t0) * 1e-9:.2f} s', fontsize=10)
        return []
    FuncAnimation(fig, draw, frames=len(frames), blit=False).save(
        gif_path, writer=PillowWriter(fps=min(fps, 50.0)))
    plt.close(fig)
    return len(frames)
