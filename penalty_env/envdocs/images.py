"""The picture at the top of each env page: one ``rgb_array`` frame of the id, as a PNG.

The frame is the id's own: ``gymnasium.make(id, render_mode="rgb_array")`` with its registered
keyword arguments, ``reset(seed=IMAGE_SEED)``, :data:`IMAGE_STEPS` steps of the zero action (the
motor off: what the start looks like once the first steps have settled it), then ``render()``.
The physics is deterministic, so the frame is the same on every run.

The PNG is written here with the standard library (``zlib``), 8-bit RGB, no filter, no metadata
(no date, no software name), so the generator needs no imaging package. Its bytes depend on the
zlib in use; its pixels do not: :func:`read_png` reads them back, and the generator compares
pixels, not bytes, before rewriting a picture, so another zlib does not rewrite the committed ones.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

__all__ = ["IMAGE_DIR", "IMAGE_SEED", "IMAGE_STEPS", "image_name", "png_bytes", "read_png", "render_frame"]

IMAGE_DIR = "img"  # the pictures' folder, beside the pages
IMAGE_SEED = 0  # the reset seed of every picture
IMAGE_STEPS = 5  # steps of the zero action before the frame

_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def image_name(env_id: str) -> str:
    """The picture's path relative to the pages' folder: ``img/<id>.png`` (a namespace's slash made a dash)."""
    return f"{IMAGE_DIR}/{env_id.replace('/', '-')}.png"


def render_frame(env_id: str) -> np.ndarray:
    """The id's picture: a ``(height, width, 3)`` uint8 frame after ``reset(seed=IMAGE_SEED)`` and
    :data:`IMAGE_STEPS` steps of the zero action."""
    env = gym.make(env_id, render_mode="rgb_array")
    try:
        env.reset(seed=IMAGE_SEED)
        space: Any = env.action_space
        zero = np.zeros(space.shape, space.dtype)
        for _ in range(IMAGE_STEPS):
            env.step(zero)
        frame = env.render()
    finally:
        env.close()
    frame = np.asarray(frame)
    if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
        raise ValueError(
            f"{env_id}: render() returned {frame.dtype} {frame.shape}, not a (height, width, 3) uint8 frame"
        )
    return frame


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_bytes(frame: np.ndarray) -> bytes:
    """``frame`` ((height, width, 3) uint8) as a PNG file: 8-bit RGB, filter 0 on every row, no metadata."""
    frame = np.ascontiguousarray(frame, dtype=np.uint8)
    if frame.ndim != 3 or frame.shape[2] != 3:
        raise ValueError(f"frame must be (height, width, 3), got {frame.shape}")
    height, width, _ = frame.shape
    rows = np.concatenate([np.zeros((height, 1), np.uint8), frame.reshape(height, width * 3)], axis=1)
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)  # 8 bits, RGB, deflate, filter 0, no interlace
    return (
        _SIGNATURE + _chunk(b"IHDR", header) + _chunk(b"IDAT", zlib.compress(rows.tobytes(), 9)) + _chunk(b"IEND", b"")
    )


def read_png(path: Path) -> np.ndarray:
    """The pixels of a PNG written by :func:`png_bytes` ((height, width, 3) uint8). Raises
    ValueError for any other kind of PNG (another colour type, filters, interlacing)."""
    data = Path(path).read_bytes()
    if not data.startswith(_SIGNATURE):
        raise ValueError(f"{path}: not a PNG file")
    at, header, idat = len(_SIGNATURE), b"", b""
    while at < len(data):
        (length,) = struct.unpack(">I", data[at : at + 4])
        kind, body = data[at + 4 : at + 8], data[at + 8 : at + 8 + length]
        at += 12 + length
        if kind == b"IHDR":
            header = body
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    if len(header) != 13:
        raise ValueError(f"{path}: no IHDR chunk")
    width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", header)
    if (depth, colour, interlace) != (8, 2, 0):
        raise ValueError(f"{path}: not an 8-bit RGB PNG without interlacing (as png_bytes writes)")
    rows = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(height, 1 + width * 3)
    if rows[:, 0].any():
        raise ValueError(f"{path}: a row uses a PNG filter (png_bytes writes filter 0 only)")
    return rows[:, 1:].reshape(height, width, 3).copy()
