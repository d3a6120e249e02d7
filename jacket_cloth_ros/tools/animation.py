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
    from PIL import Image

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
    # The axes and their text are drawn once, and each frame only draws its own artists over
    # them (blitting): matplotlib's animation cleared and laid out both axes for every frame
    # and drew each frame twice.
    for ax, (view, axis) in zip(axes, VIEWS):
        draw_view(ax, frames[0], skeleton, axis, across, upward, style)
        _clear(ax)
        ax.set_xlabel(labels[axis], fontsize=8)
        ax.set_title(f'{view} view', fontsize=9)
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    title = fig.suptitle('', fontsize=10)
    images, palette = [], None
    for f in frames:
        fig.canvas.restore_region(background)
        for ax, (_, axis) in zip(axes, VIEWS):
            _clear(ax)
            draw_view(ax, f, skeleton, axis, across, upward, style)
            for artist in ax.collections + ax.lines:
                ax.draw_artist(artist)
        title.set_text(f't = {(f.stamp_ns - t0) * 1e-9:.2f} s')
        fig.draw_artist(title)
        image = Image.fromarray(np.asarray(fig.canvas.buffer_rgba())).convert('RGB')
        # One palette, the first frame's, for all: a palette per frame was most of the time.
        if palette is None:
            palette = image.quantize(colors=255, method=Image.Quantize.FASTOCTREE)
        images.append(image.quantize(palette=palette, dither=Image.Dither.NONE))
    if images:
        images[0].save(gif_path, save_all=True, append_images=images[1:], loop=0,
                       duration=int(round(1000.0 / min(fps, 50.0))))
    plt.close(fig)
    return len(frames)


def _clear(ax):
    """Take a frame's drawing (its collections and lines) off ``ax``."""
    for artist in ax.collections[:] + ax.lines[:]:
        artist.remove()
