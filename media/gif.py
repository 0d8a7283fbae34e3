"""A looping GIF written frame by frame (``cmdp-simulate --gif``'s rollout).

:class:`GifStream` writes frames as they come, so that a long animation never sits in
memory; :func:`write_gif` writes a sequence of them. Apart from the charts because it draws
nothing: it encodes frames drawn elsewhere (``media.render.draw_frame``) and needs Pillow,
not matplotlib.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np


class GifStream:
    """A looping GIF written to disk frame by frame, so that a long animation never sits in
    memory (``cmdp-simulate --gif`` held every frame: about 1.4 GB at its peak).

    Frames go to a temporary file beside ``path``; :meth:`close` finishes it and renames it to
    ``path``, and :meth:`abort` (or leaving a ``with`` block by an exception, Ctrl-C included)
    deletes it: a crash leaves no half GIF. Only the last written frame and one pending frame
    are held. A frame equal to the one before lengthens it (as Pillow's own GIF writer merges
    them: the playing time is unchanged); a changed frame stores only the rectangle that
    changed, each with its own 256-colour palette (Pillow's adaptive palette, as for a whole
    GIF).

    Why not imageio's writer: with Pillow 13, imageio 2.38's v3 Pillow plugin keeps every frame
    until the file is closed, and its legacy streaming GIF writer (``GIF-PIL``) writes a file
    Pillow cannot read (it refuses Pillow 10.1+ for that reason). The frames are encoded with
    Pillow's own GIF encoder (``GifImagePlugin.getdata``); only the file's header, loop
    extension and trailer are written here (GIF89a).

    Args:
        path: the GIF to write.
        duration_s_per_frame: seconds a frame shows, rounded to the GIF's hundredths.
    """

    def __init__(self, path: str | Path, duration_s_per_frame: float):
        import os
        import tempfile

        if not duration_s_per_frame > 0:
            raise ValueError(f"duration_s_per_frame must be positive, not {duration_s_per_frame}")
        self.path = Path(path)
        self.centis = max(1, round(duration_s_per_frame * 100))
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, self._tmp = tempfile.mkstemp(dir=self.path.parent, prefix=f".{self.path.name}.",
                                         suffix=".tmp")
        self._file = os.fdopen(fd, "wb")
        self._shape: tuple | None = None
        self._written: np.ndarray | None = None  # what a viewer shows after the last frame
        self._pending: np.ndarray | None = None  # the newest frame, its length still growing
        self._pending_centis = 0
        self.frames = 0  # frames given
        self.stored = 0  # frames in the file (equal consecutive frames merged)

    def append(self, frame: np.ndarray) -> None:
        """Add one (H, W, 3) uint8 frame (every frame of one shape)."""
        f = np.asarray(frame)
        if self._shape is None and not (f.dtype == np.uint8 and f.ndim == 3 and f.shape[2] == 3):
            self.abort()
            raise ValueError(f"frame 0 is {f.dtype} {f.shape}; fix: every frame must be uint8 "
                             "of one shape (H, W, 3)")
        if self._shape is not None and (f.dtype != np.uint8 or f.shape != self._shape):
            self.abort()
            raise ValueError(f"frame {self.frames} is {f.dtype} {f.shape}; fix: every frame "
                             f"must be uint8 of one shape (H, W, 3), like frame 0 {self._shape}")
        if self._shape is None:
            self._shape = f.shape
            self._header(f.shape[1], f.shape[0])
        self.frames += 1
        if self._pending is not None and np.array_equal(f, self._pending):
            self._pending_centis += self.centis
            return
        self._flush()
        self._pending, self._pending_centis = f.copy(), self.centis

    def _header(self, width: int, height: int) -> None:
        o16 = _le16
        self._file.write(b"GIF89a" + o16(width) + o16(height) + bytes((0, 0, 0)))
        self._file.write(b"!\xff\x0bNETSCAPE2.0\x03\x01" + o16(0) + b"\x00")  # loop forever

    def _flush(self) -> None:
        """Write the pending frame: the rectangle that changed since the last written one."""
        from PIL import GifImagePlugin, Image

        new = self._pending
        if new is None:
            return
        top, left, bottom, right = 0, 0, new.shape[0], new.shape[1]
        if self._written is not None:
            changed = np.any(new != self._written, axis=2)
            rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
            top, bottom, left, right = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
        image = Image.fromarray(np.ascontiguousarray(new[top:bottom, left:right]))
        image = image.convert("P", palette=Image.Palette.ADAPTIVE)
        while self._pending_centis > 0:  # a delay holds at most 65535 hundredths
            centis = min(self._pending_centis, 65535)
            for chunk in GifImagePlugin.getdata(
                    image, (int(left), int(top)), duration=10 * centis, disposal=1,
                    include_color_table=True):
                self._file.write(chunk)
            self._pending_centis -= centis
            self.stored += 1
        self._written, self._pending = new, None

    def close(self) -> Path:
        """Finish the file and move it to ``path``; returns the path."""
        import os

        if self._pending is None and self._written is None:
            self.abort()
            raise ValueError("no frames to write; fix: pass at least one (H, W, 3) uint8 frame")
        try:
            self._flush()
            self._file.write(b";")
            self._file.close()
            os.chmod(self._tmp, 0o644)
            os.replace(self._tmp, self.path)
        except BaseException:
            self.abort()
            raise
        return self.path

    def abort(self) -> None:
        """Delete the unfinished file (safe to call twice)."""
        import os

        self._file.close()
        if os.path.exists(self._tmp):
            os.unlink(self._tmp)

    def __enter__(self) -> GifStream:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()


def _le16(value: int) -> bytes:
    return int(value).to_bytes(2, "little")


def write_gif(frames: Iterable[np.ndarray], path: str | Path,
              duration_s_per_frame: float) -> Path:
    """Write (H, W, 3) uint8 frames as a looping GIF, atomically, one frame at a time
    (:class:`GifStream`); returns the path.

    GIF stores durations in hundredths of a second, so ``duration_s_per_frame`` is rounded to
    that. Consecutive identical frames are merged into one longer frame (the playing time
    is unchanged), so the file may hold fewer frames than were given.
    """
    with GifStream(path, duration_s_per_frame) as gif:
        for frame in frames:
            gif.append(frame)
    return gif.path
