"""The env pages under ``docs/envs/`` (``python -m penalty_env.envdocs``) are the generator's output
for the ids registered now: none stale, none missing, none extra, and the README links them.

The generator's own logic is checked on an env made for the test: a class with several observation
modes gets one space per mode (a mode the id refuses says so), a section under a rule appears only
where the rule holds, and ``check`` names a stale, a missing and an extra page.
"""

from __future__ import annotations

import pathlib
import re
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

from penalty_env import envdocs
from penalty_env.envdocs.images import png_bytes, read_png

ROOT = pathlib.Path(__file__).resolve().parents[2]
PAGES = ROOT / "docs" / "envs"


@pytest.fixture(scope="module")
def generated():
    """Every page as the generator writes it now (each id made once; nothing stepped). No "v0 is
    out of date" note either: the package drops it for its ids even under pytest's filters."""
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message=r".*is out of date", category=DeprecationWarning)
        return envdocs.generate()


def test_committed_pages_are_the_generated_ones(generated):
    problems = envdocs.check(PAGES, generated)
    assert not problems, "run python -m penalty_env.envdocs:\n" + "\n".join(problems)


def test_pages_do_not_depend_on_the_callers_print_options(generated):
    with np.printoptions(precision=2, linewidth=30, threshold=4, floatmode="fixed", sign="+"):
        assert envdocs.generate() == generated


def test_every_registered_id_has_a_page_and_every_page_a_registered_id():
    ids = envdocs.penalty_ids()
    assert "PenaltyBalls-v0" in ids and "PenaltyBallsSand2D-v1" in ids
    for env_id in ids:
        assert (PAGES / envdocs.page_name(env_id)).is_file(), env_id
    registered = set(gym.registry)
    pages = sorted(p for p in PAGES.glob("*.md") if p.name != envdocs.INDEX)
    assert len(pages) == len(ids)
    for page in pages:
        title = page.read_text(encoding="utf-8").splitlines()[0]
        assert title.startswith("# ")
        env_id = title[2:]
        assert env_id in registered and envdocs.page_name(env_id) == page.name, page.name
    index = (PAGES / envdocs.INDEX).read_text(encoding="utf-8")
    for env_id in ids:
        assert f"[{env_id}]({envdocs.page_name(env_id)})" in index


def test_each_page_opens_with_its_ids_picture():
    """As Gymnasium's pages: the picture right under the title (the generator's comment between),
    a PNG of the id's rgb_array frame, committed beside the page."""
    for env_id in envdocs.penalty_ids():
        lines = (PAGES / envdocs.page_name(env_id)).read_text(encoding="utf-8").splitlines()
        link = f"img/{env_id}.png"
        assert lines[4] == f"![{env_id}]({link})", (env_id, lines[:6])
        frame = read_png(PAGES / link)
        assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8
        assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 2, env_id  # a picture, not a blank


def test_a_picture_rendered_again_has_the_committed_pixels(generated):
    """One id rendered again (the others are the same code; ``--check --render`` does every id):
    the frame is the committed picture's, and the same frame twice makes the same PNG bytes."""
    env_id = "PenaltyBalls2D-v0"
    frames = envdocs.generate_images([env_id])
    assert list(frames) == [f"img/{env_id}.png"]
    assert envdocs.check(PAGES, generated, frames) == []
    again = envdocs.generate_images([env_id])[f"img/{env_id}.png"]
    assert png_bytes(again) == png_bytes(frames[f"img/{env_id}.png"])


def test_readme_links_the_pages():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert re.search(r"\]\(docs/envs/(README\.md)?\)", readme)


def test_sections_follow_the_rule_and_carry_each_ids_facts(generated):
    for env_id in envdocs.penalty_ids():
        page = generated[envdocs.page_name(env_id)]
        spec = gym.spec(env_id)
        sand = spec.kwargs.get("grains", 0) > 0
        assert ("\n## Sand\n" in page) == sand, env_id
        for title in ("Description", "Action Space", "Observation Space", "Rewards", "Episode End", "Version History"):
            assert f"\n## {title}\n" in page, (env_id, title)
        assert f"truncation after {spec.max_episode_steps} steps" in page
        assert f'`gymnasium.make("{env_id}")`' in page


def test_pages_say_how_to_install_from_a_clone(generated):
    """The package is not on PyPI: a page that names an extra says to install it from the clone."""
    rendering = 0
    for name, page in generated.items():
        assert 'pip install "penalty-env' not in page, name
        if "pygame window" in page:
            rendering += 1
            assert 'pip install -e ".[render]"' in page, name
    assert rendering > 0  # the PenaltyBalls pages describe the human mode


class _Modes(gym.Env):
    """A test env with two observation modes and one it refuses."""

    OBS_MODES = ("state", "pixels", "sound")

    def __init__(self, obs_mode="state", grains=0):
        if obs_mode == "sound":
            raise ValueError(f"obs_mode must be 'state' or 'pixels', got {obs_mode!r}")
        self.dim = 2
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        if obs_mode == "state":
            low, high = np.array([-1.0, 0.0], np.float32), np.array([1.0, 3.5], np.float32)
            self.observation_space = spaces.Box(low, high, dtype=np.float32)
        else:
            self.observation_space = spaces.Box(0, 255, (8, 8, 3), np.uint8)

    def reset(self, *, seed=None, options=None):
        raise AssertionError("the generator must not reset")

    def step(self, action):
        raise AssertionError("the generator must not step")


_Modes.__doc__ = """
    ## Description

    A test.

    ## Sand

    Only with grains.

    ## Version History

    * v0: the test's.
    """


def test_observation_modes_rules_and_check(tmp_path):
    env_id = "EnvdocsModesTest-v0"
    gym.register(env_id, entry_point=_Modes, max_episode_steps=7, kwargs={"obs_mode": "pixels"})
    try:
        facts = envdocs.env_facts(env_id)
        page = envdocs.render_page(facts)
    finally:
        del gym.registry[env_id]
    assert [m for m, _ in facts.modes] == ["state", "pixels", "sound"]
    assert facts.obs_mode == "pixels"  # the registered mode
    # each mode's space, made in that mode; the summary table shows the registered mode's
    assert '| Observation Space (`obs_mode="pixels"`) | `Box(0, 255, (8, 8, 3), uint8)` |' in page
    assert "state: Box([-1. 0.], [1. 3.5], (2,), float32)" in page
    assert "pixels: Box(0, 255, (8, 8, 3), uint8)" in page
    assert "not available on this id (ValueError: obs_mode must be 'state' or 'pixels', got 'sound')" in page
    # no grains: no Sand section; the facts' sections the docstring lacks come before the history
    assert "## Sand" not in page
    titles = re.findall(r"^## (.+)$", page, flags=re.M)
    assert titles == ["Description", "Observation Space", "Episode End", "Arguments", "Version History"]
    assert "truncation after 7 steps" in page
    facts.params["grains"] = 5
    assert "\n## Sand\n\nOnly with grains.\n" in envdocs.render_page(facts)

    pages = {"A-v0.md": "a\n", "B-v0.md": "b\n", envdocs.INDEX: "index\n"}
    assert envdocs.write(tmp_path, pages) == [f"added: {tmp_path / name}" for name in pages]
    assert envdocs.check(tmp_path, pages) == []
    (tmp_path / "A-v0.md").write_text("edited\n")
    (tmp_path / "B-v0.md").unlink()
    (tmp_path / "C-v0.md").write_text("c\n")
    assert envdocs.check(tmp_path, pages) == [
        f"stale: {tmp_path / 'A-v0.md'}",
        f"missing: {tmp_path / 'B-v0.md'}",
        f"extra: {tmp_path / 'C-v0.md'}",
    ]


def test_pictures_are_checked_and_written_by_their_pixels(tmp_path):
    """``check`` names a missing, an unreadable, an extra and (given frames) a stale picture;
    ``write_images`` rewrites a picture only when its pixels change and removes one no page shows."""
    rng = np.random.default_rng(0)
    frame_a = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    frame_b = rng.integers(0, 256, (4, 3, 3), dtype=np.uint8)
    assert np.array_equal(read_png_bytes(tmp_path, png_bytes(frame_a)), frame_a)  # the round trip
    pages = {"A-v0.md": "# A-v0\n\n![A-v0](img/A-v0.png)\n", "B-v0.md": "![B](img/B-v0.png)\n"}
    envdocs.write(tmp_path, pages)
    img = tmp_path / "img"
    assert envdocs.check(tmp_path, pages) == [f"missing: {img / 'A-v0.png'}", f"missing: {img / 'B-v0.png'}"]

    frames = {"img/A-v0.png": frame_a, "img/B-v0.png": frame_b}
    assert envdocs.write_images(tmp_path, frames) == [f"added: {img / 'A-v0.png'}", f"added: {img / 'B-v0.png'}"]
    assert envdocs.check(tmp_path, pages, frames) == []
    # the same pixels in other bytes (as another zlib would write them) are left alone
    (img / "A-v0.png").write_bytes(png_bytes_level(frame_a, 1))
    other_bytes = (img / "A-v0.png").read_bytes()
    assert other_bytes != png_bytes(frame_a)
    assert envdocs.write_images(tmp_path, frames) == []
    assert (img / "A-v0.png").read_bytes() == other_bytes

    changed = frame_a.copy()
    changed[0, 0] ^= 1
    assert envdocs.check(tmp_path, pages, {**frames, "img/A-v0.png": changed}) == [f"stale: {img / 'A-v0.png'}"]
    (img / "B-v0.png").write_bytes(b"not a png")
    (img / "C-v0.png").write_bytes(png_bytes(frame_b))
    problems = envdocs.check(tmp_path, pages)
    assert problems[0].startswith(f"unreadable: {img / 'B-v0.png'} (") and "not a PNG" in problems[0]
    assert problems[1:] == [f"extra: {img / 'C-v0.png'}"]
    assert envdocs.write_images(tmp_path, frames) == [f"updated: {img / 'B-v0.png'}", f"removed: {img / 'C-v0.png'}"]
    assert envdocs.check(tmp_path, pages, frames) == []


def read_png_bytes(folder, data):
    path = folder / "roundtrip.png"
    path.write_bytes(data)
    try:
        return read_png(path)
    finally:
        path.unlink()


def png_bytes_level(frame, level):
    """``png_bytes`` with another zlib level: the same pixels in other bytes."""
    import zlib

    data = png_bytes(frame)
    signature, rest = data[:8], data[8:]
    chunks, at = [], 0
    while at < len(rest):
        length = int.from_bytes(rest[at : at + 4], "big")
        kind, body = rest[at + 4 : at + 8], rest[at + 8 : at + 8 + length]
        if kind == b"IDAT":
            body = zlib.compress(zlib.decompress(body), level)
        crc = zlib.crc32(kind + body).to_bytes(4, "big")
        chunks.append(len(body).to_bytes(4, "big") + kind + body + crc)
        at += 12 + length
    return signature + b"".join(chunks)
