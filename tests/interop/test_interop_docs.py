"""docs/interop.md: every code block on the page runs, so the page cannot go stale.

A block is named by the ``<!-- snippet: NAME -->`` comment on the line above it (``slow`` after the
name: it starts worker processes). The default run executes the other blocks one after the other,
in page order, in one fresh interpreter (a runner script, so that TorchRL's import, which sets the
multiprocessing start method to ``spawn``, stays out of the test process), with the working
directory a temporary folder holding a link to ``train/`` and ``MINARI_DATASETS_PATH`` inside it.
Each slow block runs as a script of its own, as a user would run it (spawned workers re-import it).
A block whose library is not installed is skipped; CI installs the ``interop`` extra, so none is.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "interop.md"
SNIPPET = re.compile(r"<!-- snippet: ([\w-]+)( slow)? -->\n```(python|bash)\n(.*?)\n```", re.S)

# the modules each block needs (by the block name's first word)
NEEDS = {
    "sb3": ["stable_baselines3"],
    "zoo": ["rl_zoo3"],
    "cleanrl": ["torch"],
    "gymnasium": [],
    "torchrl": ["torchrl", "tensordict"],
    "skrl": ["skrl", "torch"],
    "tianshou": ["tianshou"],
    "minari": ["minari", "h5py", "jax"],
}
# what a block prints (one string, or several), where the page says so in a comment
PRINTS = {
    "cleanrl": "length 150",
    "sb3-subproc": "(2, 21)",
    "gymnasium-async": "(2, 21)",
    "torchrl": ("torch.Size([8, 200])", "['is_success']"),
    "torchrl-gymenv": "torch.Size([2, 10])",
    "torchrl-parallel": "torch.Size([2, 64, 10])",
    "tianshou": "256",
    "tianshou-envs": "(4, 21)",
    "tianshou-subproc": "(2, 21)",
    "minari-load": "10 ",
}


def snippets() -> list[tuple[str, bool, str, str]]:
    """(name, slow, language, code) of every named block, in page order."""
    return [(m[1], bool(m[2]), m[3], m[4]) for m in SNIPPET.finditer(PAGE.read_text())]


def _missing(name: str) -> list[str]:
    return [m for m in NEEDS[name.split("-")[0]] if importlib.util.find_spec(m) is None]


def _check_prints(name: str, out: str) -> None:
    expected = PRINTS.get(name, ())
    for text in (expected,) if isinstance(expected, str) else expected:
        assert text in out, out


def _environment(folder: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env["MINARI_DATASETS_PATH"] = str(folder / "datasets")
    env.pop("PYTEST_CURRENT_TEST", None)
    return env


def _folder(tmp: Path) -> Path:
    (tmp / "train").symlink_to(ROOT / "train", target_is_directory=True)
    return tmp


RUNNER = """
import contextlib, io, json, os, subprocess, sys, time, traceback
blocks = json.load(open(sys.argv[1]))
results = {}
for name, language, code in blocks:
    out, start = io.StringIO(), time.perf_counter()
    try:
        with contextlib.redirect_stdout(out):
            if language == "python":
                exec(compile(code, f"<docs/interop.md: {name}>", "exec"), {"__name__": "__main__"})
        if language == "bash":
            res = subprocess.run(["bash", "-euo", "pipefail", "-c", code], capture_output=True, text=True)
            out.write(res.stdout)
            if res.returncode:
                raise RuntimeError(f"exit {res.returncode}: {res.stderr[-3000:]}")
        results[name] = {"ok": True, "out": out.getvalue(), "seconds": time.perf_counter() - start}
    except BaseException:
        results[name] = {"ok": False, "out": out.getvalue(), "error": traceback.format_exc()[-4000:]}
json.dump(results, open(sys.argv[2], "w"))
"""


@pytest.fixture(scope="module")
def fast_results(tmp_path_factory):
    """Run every default block, in page order, in one fresh interpreter; name -> result."""
    folder = _folder(tmp_path_factory.mktemp("interop_docs"))
    blocks = [(name, lang, code) for name, slow, lang, code in snippets() if not slow and not _missing(name)]
    (folder / "blocks.json").write_text(json.dumps(blocks))
    (folder / "runner.py").write_text(RUNNER)
    res = subprocess.run(
        [sys.executable, "runner.py", "blocks.json", "results.json"],
        cwd=folder,
        env=_environment(folder),
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    return json.loads((folder / "results.json").read_text())


def test_every_block_on_the_page_is_named_once():
    blocks = re.findall(r"^```(\w*)$", PAGE.read_text(), re.M)
    names = [s[0] for s in snippets()]
    assert len(names) == len(blocks) // 2  # an opening and a closing fence per block: each is named
    assert len(set(names)) == len(names)
    assert {name.split("-")[0] for name in names} <= set(NEEDS)
    assert set(PRINTS) <= set(names)


@pytest.mark.parametrize("name", [s[0] for s in snippets() if not s[1]])
def test_snippet(name, fast_results):
    missing = _missing(name)
    if missing:
        pytest.skip(f"{', '.join(missing)} not installed (the interop extra)")
    result = fast_results[name]
    assert result["ok"], result["error"]
    _check_prints(name, result["out"])


@pytest.mark.slow
@pytest.mark.parametrize("name", [s[0] for s in snippets() if s[1]])
def test_slow_snippet(name, tmp_path):
    missing = _missing(name)
    if missing:
        pytest.skip(f"{', '.join(missing)} not installed")
    (_, _, language, code) = next(s for s in snippets() if s[0] == name)
    folder = _folder(tmp_path)
    script = folder / ("snippet.py" if language == "python" else "snippet.sh")
    script.write_text(code + "\n")
    cmd = [sys.executable, script.name] if language == "python" else ["bash", "-euo", "pipefail", script.name]
    res = subprocess.run(cmd, cwd=folder, env=_environment(folder), capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    _check_prints(name, res.stdout)
