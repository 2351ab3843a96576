"""Rendering: readable rgb_array frames, fast enough for video, a headless human window, and
Gymnasium's RecordVideo."""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import gymnasium as gym
import numpy as np
import pytest

import penalty_env  # noqa: F401
from penalty_env.envs.views import raster as R


def color_near(frame, rgb, tol=60):
    """Pixels whose colour is within ``tol`` of ``rgb`` (0-255)."""
    return np.all(np.abs(frame.astype(int) - np.array(rgb)) < tol, axis=-1)


def pixel(scene, renderer, point):
    """Image (row, col) of a world point (3D top view)."""
    s = renderer.scale
    return int(renderer.height / 2 - point[1] * s), int(renderer.width / 2 + point[0] * s)


@pytest.mark.parametrize("env_id", ["PenaltyBalls-v0", "PenaltyBalls2D-v0"])
def test_rgb_array_frame_shows_the_bodies_and_the_goal(env_id):
    env = gym.make(env_id, render_mode="rgb_array", n_obstacles=1, render_width=200, render_height=160)
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (160, 200, 3) and frame.dtype == np.uint8
    for color in (R.PUSHER_COLOR, R.BALL_COLOR, R.OBSTACLE_COLOR, R.GOAL_COLOR):
        assert color_near(frame, 255 * np.array(color), 50).sum() > 10, color


def test_3d_frame_puts_the_ball_where_it_is():
    env = gym.make("PenaltyBalls-v0", render_mode="rgb_array")
    env.reset(seed=1)
    scene = env.unwrapped.scene
    frame = env.render()
    renderer = env.unwrapped._renderer
    row, col = pixel(scene, renderer, scene.world.positions[0, 1])
    patch = frame[row - 2 : row + 3, col - 2 : col + 3].reshape(-1, 3).astype(int)
    # the ball's centre is lit orange: red well above blue (the sand and the pusher are not)
    assert np.all(patch[:, 0] > patch[:, 2] + 60)


def test_frames_render_at_video_speed():
    env = gym.make("PenaltyBalls-v0", render_mode="rgb_array", n_obstacles=3)
    env.reset(seed=0)
    env.render()
    n = 200
    t = time.perf_counter()
    for _ in range(n):
        env.unwrapped.render()
    fps = n / (time.perf_counter() - t)
    assert fps > 200, f"{fps:.0f} frames per second at 256x256"


@pytest.mark.parametrize("env_id", ["PenaltyBalls-v0", "PenaltyBalls2D-v0"])
def test_human_mode_opens_a_window_headless(env_id):
    pytest.importorskip("pygame")
    env = gym.make(env_id, render_mode="human", render_width=64, render_height=64)
    env.unwrapped.metadata["render_fps"] = 1000  # don't sleep in the test
    env.reset(seed=0)
    for _ in range(3):
        env.step(env.action_space.sample())
    assert env.unwrapped._window is not None
    env.close()
    assert env.unwrapped._window is None


def test_human_mode_without_pygame_says_how_to_install_it(monkeypatch):
    """The package is installed from a clone, not from PyPI: the message names the clone's extra."""
    from gymnasium.error import DependencyNotInstalled

    from penalty_env.envs.views.render import HumanWindow

    monkeypatch.setitem(sys.modules, "pygame", None)  # import pygame raises ImportError
    with pytest.raises(DependencyNotInstalled, match=r'pip install -e "\.\[render\]" from the repository'):
        HumanWindow(64, 64, fps=25.0)


def test_record_video_writes_a_file(tmp_path):
    pytest.importorskip("moviepy")
    env = gym.make("PenaltyBalls-v0", render_mode="rgb_array", max_episode_steps=10, render_width=64, render_height=64)
    env = gym.wrappers.RecordVideo(env, str(tmp_path / "videos"), episode_trigger=lambda ep: True, disable_logger=True)
    env.reset(seed=0)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        done = terminated or truncated
    env.close()
    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert videos and videos[0].stat().st_size > 0
