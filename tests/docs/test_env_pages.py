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

ROOT = pathlib.Path(__file__).resolve().parents[2]
PAGES = ROOT / "docs" / "envs"


@pytest.fixture(scope="module")
def generated():
    """Every page as the generator writes it now (each id made once; nothing stepped)."""
    with warnings.catch_warnings():  # Gymnasium's "v0 is out of date" (the package's own filter is reset by pytest)
        warnings.filterwarnings("ignore", message=r".*is out of date", category=DeprecationWarning)
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
