"""The env pages: one Markdown page per registered penalty_env id under ``docs/envs/``, generated from the code.

Run: ``python -m penalty_env.envdocs`` (writes the pages and their pictures) or
``python -m penalty_env.envdocs --check`` (writes nothing; exits 1 listing every page that is stale,
missing or extra, and every picture a page shows that is missing or unreadable; ``--render`` also
renders each picture again and compares its pixels with the committed one's).

The ids are read from ``gymnasium.registry``: every id whose entry point is a string starting with
``penalty_env.``, in registration order, so an id added to the package gets its page at the next
run. Each page follows the layout of Gymnasium's own env pages: the id as the title, a picture
of the env (``img/<id>.png``: :mod:`.images`, one ``rgb_array`` frame after ``reset(seed=0)`` and a
few steps of the zero action), a one-line summary, a table (action space, observation space, the id's registered keyword arguments,
``max_episode_steps``, the ``gymnasium.make`` and ``gymnasium.make_vec`` lines), then the sections
of the env class's docstring (``## Description``, ``## Action Space``, ...) in the docstring's
order, with the id's own facts added to the section they belong to:

  - **Observation Space**: the space of every observation mode the class supports
    (``getattr(cls, "OBS_MODES", ("state",))``; with more than one, the env is made once per mode
    with ``obs_mode=``), its bounds entry by entry;
  - **Episode End**: the registered ``max_episode_steps`` and the simulated time it spans;
  - **Physics**: the derived contact model (``env.unwrapped.scene.describe()``);
  - **Arguments**: the keyword arguments the id registers.

A section the docstring lacks is added before ``## Version History`` when the id has a fact for
it. A section applies to every id unless :data:`SECTION_RULES` names it: a rule keeps it only on
the ids it holds for (today one rule: ``## Sand`` only on ids with sand grains). The facts come
from making the env with the id's registered keyword arguments (``gymnasium.make(id)``) and reading
its spaces and scene; nothing is stepped for them (a sand id settles its bed once, kept on disk
by :mod:`penalty_env._results`); only the pictures step each id, a few steps of the zero action.
``docs/envs/README.md`` is the index: one row per id.

The output is deterministic: no dates, no addresses, NumPy's print options fixed while the bounds
are written; the pictures are rewritten only when their pixels change (so another zlib, which may
compress the same pixels into other bytes, rewrites none). ``tests/docs/test_env_pages.py``
compares the committed pages with this output and renders one id's picture again, so a page cannot
go stale unnoticed: after editing a docstring or a registration, rerun the generator and commit its
pages and pictures.
"""

from __future__ import annotations

import argparse
import inspect
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import images as _images
from .facts import (
    INDEX,
    MARKER,
    SECTION_RULES,
    VEC_NUM_ENVS,
    EnvFacts,
    _bounds_block,
    env_facts,
    page_name,
    penalty_ids,
    space_cell,
    space_shape,
)

__all__ = [
    "SECTION_RULES",
    "EnvFacts",
    "check",
    "default_dir",
    "env_facts",
    "generate",
    "generate_images",
    "main",
    "page_name",
    "penalty_ids",
    "render_index",
    "render_page",
    "write",
]


def _markdown(text: str) -> str:
    """Sphinx roles and double backquotes of a docstring as Markdown code spans."""
    text = re.sub(r":[a-z]+:`~?([^`]+)`", r"`\1`", text)
    return re.sub(r"``([^`]+)``", r"`\1`", text)


def docstring_sections(cls: type) -> tuple[str, list[tuple[str, str]]]:
    """The class docstring's text before its first ``## `` heading, and its ``(title, body)``
    sections in order (``###`` subsections stay in their section's body)."""
    doc = _markdown(inspect.cleandoc(cls.__doc__ or ""))
    head: list[str] = []
    sections: list[tuple[str, list[str]]] = []
    for line in doc.splitlines():
        if line.startswith("## "):
            sections.append((line[3:].strip(), []))
        elif sections:
            sections[-1][1].append(line)
        else:
            head.append(line)
    return "\n".join(head).strip(), [(title, "\n".join(body).strip()) for title, body in sections]


def class_summary(cls: type) -> str:
    """The task in one sentence: the class docstring's first paragraph when it comes before the
    first heading, else its module docstring's first line (a leading ``Name:`` dropped)."""
    head, _ = docstring_sections(cls)
    text = head.split("\n\n")[0] if head else ""
    if not text:
        module_doc = inspect.cleandoc(sys.modules[cls.__module__].__doc__ or "")
        text = module_doc.split("\n\n")[0]
        text = re.sub(r"^\w[\w-]*: ", "", text)
    text = " ".join(text.split())
    return text[:1].upper() + text[1:] if text else cls.__name__


# ----------------------------------------------------------------------------------------------
# Pages
# ----------------------------------------------------------------------------------------------
def _value(v: Any) -> str:
    return f'"{v}"' if isinstance(v, str) else repr(v)


def _kwargs_text(kwargs: dict[str, Any]) -> str:
    return ", ".join(f"{k}={_value(v)}" for k, v in kwargs.items())


def _mode_label(mode: Any) -> str:
    return f"`obs_mode={_value(mode)}`"


def _observation_facts(facts: EnvFacts) -> str:
    several = len(facts.modes) > 1
    lines = [
        "### Observation modes" if several else "### The space on this id",
        "",
        (
            f"`{facts.cls.__name__}` supports {len(facts.modes)} observation modes (`OBS_MODES`); "
            f"`{facts.env_id}` registers {_mode_label(facts.obs_mode)}. The spaces, from making the env in each mode:"
            if several
            else f"`{facts.env_id}` has one observation mode, {_mode_label(facts.obs_mode)}; its space, "
            "from making the env, entry by entry:"
        ),
        "",
    ]
    for mode, space in facts.modes:
        if several:
            lines += [f"{_mode_label(mode)}:", ""]
        if isinstance(space, str):
            lines += [space, ""]
            continue
        lines += ["```text", *_bounds_block(space, mode if isinstance(mode, str) else ""), "```", ""]
    return "\n".join(lines).strip()


def _fact_sections(facts: EnvFacts) -> dict[str, str]:
    """The id's facts, keyed by the docstring section they are added to."""
    out = {"Observation Space": _observation_facts(facts)}
    end = f"On `{facts.env_id}`: "
    if facts.max_episode_steps is None:
        end += "no time limit is registered (no truncation)."
    else:
        end += f"truncation after {facts.max_episode_steps} steps"
        if facts.control_period:
            end += (
                f" ({facts.max_episode_steps * facts.control_period:.6g} s of simulated time at "
                f"`control_period` = {facts.control_period:g} s)"
            )
        end += ", the registered `max_episode_steps`."
    out["Episode End"] = end
    if facts.describe:
        out["Physics"] = f"On `{facts.env_id}` (`env.unwrapped.scene.describe()`): {facts.describe}."
    registered = (
        f"`{facts.env_id}` registers `{_kwargs_text(facts.kwargs)}`"
        if facts.kwargs
        else f"`{facts.env_id}` registers no keyword arguments"
    )
    out["Arguments"] = (
        f"{registered}; every other keyword takes its default, and a keyword passed to "
        f'`gymnasium.make("{facts.env_id}", ...)` overrides the registered one.'
    )
    return out


def _applies(title: str, facts: EnvFacts) -> bool:
    rule = SECTION_RULES.get(title)
    return rule is None or rule[1](facts)


def render_page(facts: EnvFacts) -> str:
    """The page of one id (Markdown, ending in one newline)."""
    env_id, cls = facts.env_id, facts.cls
    _, sections = docstring_sections(cls)
    sections = [(t, b) for t, b in sections if _applies(t, facts)]
    extra = _fact_sections(facts)
    titles = [t for t, _ in sections]
    for title in extra:  # a section the docstring lacks: added before the history
        if title not in titles:
            at = titles.index("Version History") if "Version History" in titles else len(titles)
            sections.insert(at, (title, ""))
            titles.insert(at, title)
    mode_note = f" ({_mode_label(facts.obs_mode)})" if len(facts.modes) > 1 else ""
    kwargs = f"`{_kwargs_text(facts.kwargs)}`" if facts.kwargs else "none"
    steps = "none" if facts.max_episode_steps is None else str(facts.max_episode_steps)
    if facts.max_episode_steps is not None and facts.control_period:
        steps += f" ({facts.max_episode_steps * facts.control_period:.6g} s of simulated time)"
    lines = [
        f"# {env_id}",
        "",
        f"{MARKER} from `{cls.__module__}.{cls.__qualname__}`'s docstring and the registry: "
        "edit those and rerun it; `--check` fails on a stale page. -->",
        "",
        f"![{env_id}]({_images.image_name(env_id)})",
        "",
        f"*`{env_id}` after `reset(seed={_images.IMAGE_SEED})` and {_images.IMAGE_STEPS} steps of the zero action "
        '(`render_mode="rgb_array"`).*',
        "",
        f"{class_summary(cls)} This id: {facts.variant()}.",
        "",
        "| | |",
        "|---|---|",
        f"| Action Space | `{space_cell(facts.action_space)}` |",
        f"| Observation Space{mode_note} | `{space_cell(facts.observation_space)}` |",
        f"| Registered kwargs | {kwargs} |",
        f"| max_episode_steps | {steps} |",
        f'| import | `gymnasium.make("{env_id}")` |',
        f'| vector | `gymnasium.make_vec("{env_id}", num_envs={VEC_NUM_ENVS}, vectorization_mode="vector_entry_point")` |',
        "",
    ]
    for title, body in sections:
        parts = [body] if body else []
        if title in extra:
            parts.append(extra[title])
        lines += [f"## {title}", "", "\n\n".join(parts), ""]
    return "\n".join(lines).rstrip("\n") + "\n"


def render_index(all_facts: Sequence[EnvFacts]) -> str:
    """``docs/envs/README.md``: one row per id, and how the pages are made."""
    rules = "; ".join(f"`## {t}` only on {words}" for t, (words, _) in SECTION_RULES.items())
    lines = [
        "# The environments",
        "",
        f"{MARKER}: rerun it after changing an env's docstring or registration. -->",
        "",
        "One page per registered id, generated from the env class's docstring (Gymnasium's layout: "
        "a picture of the id (`img/<id>.png`, its `rgb_array` frame), description, action space, observation space per mode, rewards, starting state, episode end, "
        "arguments, version history) and from the id's registration and the env it makes "
        "(`python -m penalty_env.envdocs`; `--check` and `tests/docs/test_env_pages.py` fail on a stale "
        f"page). Every docstring section appears on every page of its class except: {rules}.",
        "",
        "| id | class | dim | summary | action space | observation space | episode |",
        "|---|---|---|---|---|---|---|",
    ]
    for f in all_facts:
        lines.append(
            f"| [{f.env_id}]({page_name(f.env_id)}) | `{f.cls.__name__}` | {f.dim or ''} | {f.variant()} | "
            f"`{space_shape(f.action_space)}` | `{space_shape(f.observation_space)}` | {f.episode()} |"
        )
    return "\n".join(lines) + "\n"


def generate(ids: Sequence[str] | None = None) -> dict[str, str]:
    """Every page (file name -> text), the index included, for ``ids`` (default: :func:`penalty_ids`)."""
    all_facts = [env_facts(env_id) for env_id in (penalty_ids() if ids is None else ids)]
    pages = {page_name(f.env_id): render_page(f) for f in all_facts}
    pages[INDEX] = render_index(all_facts)
    return pages


def generate_images(ids: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """Every page's picture (path under the pages' folder, ``img/<id>.png`` -> frame) for ``ids``
    (default: :func:`penalty_ids`): :func:`.images.render_frame`, one env made and stepped per id."""
    return {
        _images.image_name(env_id): _images.render_frame(env_id) for env_id in (penalty_ids() if ids is None else ids)
    }


# ----------------------------------------------------------------------------------------------
# Writing and checking
# ----------------------------------------------------------------------------------------------
def default_dir() -> Path:
    """``docs/envs`` of the source checkout this package is imported from."""
    root = Path(__file__).resolve().parents[2]
    if not (root / "pyproject.toml").is_file():
        raise FileNotFoundError(
            f"penalty_env is imported from {root}, not from a source checkout: pass --out DIR to write the pages there"
        )
    return root / "docs" / "envs"


_IMAGE_LINK = re.compile(r"!\[[^\]]*\]\(([^)\s]+)\)")


def image_links(pages: dict[str, str]) -> list[str]:
    """The pictures the ``pages`` show (Markdown image links), relative to the pages' folder, in order."""
    return [link for text in pages.values() for link in _IMAGE_LINK.findall(text)]


def check(out: Path, pages: dict[str, str] | None = None, frames: dict[str, np.ndarray] | None = None) -> list[str]:
    """The differences between the pages in ``out`` and the generated ``pages`` (default: generated
    now), one line each (``stale: X.md``, ``missing: X.md``, ``extra: X.md``); empty when up to date.

    The pictures: every picture a page links must be a readable PNG in ``out`` (``missing: img/X.png``,
    ``unreadable: img/X.png (why)``), and a PNG in ``out/img`` that no page links is ``extra``. With
    ``frames`` (:func:`generate_images`), a picture whose pixels differ from its frame is ``stale``.
    Without them no env is rendered: the check stays as fast as the pages'."""
    pages = generate() if pages is None else pages
    problems = []
    for name, text in pages.items():
        path = out / name
        if not path.is_file():
            problems.append(f"missing: {path}")
        elif path.read_text(encoding="utf-8") != text:
            problems.append(f"stale: {path}")
    problems += [f"extra: {p}" for p in sorted(out.glob("*.md")) if p.name not in pages]
    links = image_links(pages)
    for link in links:
        path = out / link
        if not path.is_file():
            problems.append(f"missing: {path}")
            continue
        try:
            pixels = _images.read_png(path)
        except ValueError as exc:
            problems.append(f"unreadable: {path} ({exc})")
            continue
        if frames is not None and link in frames and not np.array_equal(pixels, frames[link]):
            problems.append(f"stale: {path}")
    linked = {(out / link).resolve() for link in links}
    problems += [f"extra: {p}" for p in sorted((out / _images.IMAGE_DIR).glob("*.png")) if p.resolve() not in linked]
    return problems


def write_images(out: Path, frames: dict[str, np.ndarray]) -> list[str]:
    """Write each frame (``img/<id>.png`` -> pixels) as a PNG under ``out`` where the file is missing
    or its pixels differ (same pixels: the file is left as it is, whatever zlib wrote it); delete
    the PNGs in ``out/img`` that are not among the ``frames`` (that folder is the generator's).
    Returns what changed, one line per file."""
    changed = []
    for link, frame in frames.items():
        path = out / link
        old, existed = None, path.is_file()
        if existed:
            try:
                old = _images.read_png(path)
            except ValueError:
                old = None
        if old is None or not np.array_equal(old, frame):
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(_images.png_bytes(frame))
            changed.append(f"{'updated' if existed else 'added'}: {path}")
    wanted = {(out / link).resolve() for link in frames}
    for path in sorted((out / _images.IMAGE_DIR).glob("*.png")):
        if path.resolve() not in wanted:
            path.unlink()
            changed.append(f"removed: {path}")
    return changed


def write(out: Path, pages: dict[str, str] | None = None) -> list[str]:
    """Write the ``pages`` (default: generated now) into ``out``; delete the generated pages of ids
    no longer registered (a page without the generator's mark is left alone). Returns what changed,
    one line per file."""
    pages = generate() if pages is None else pages
    out.mkdir(parents=True, exist_ok=True)
    changed = []
    for name, text in pages.items():
        path = out / name
        old = path.read_text(encoding="utf-8") if path.is_file() else None
        if old != text:
            path.write_text(text, encoding="utf-8", newline="\n")
            changed.append(f"{'updated' if old is not None else 'added'}: {path}")
    for path in sorted(out.glob("*.md")):
        if path.name in pages:
            continue
        if MARKER in path.read_text(encoding="utf-8"):
            path.unlink()
            changed.append(f"removed: {path}")
        else:
            changed.append(f"kept (not written by this generator; --check lists it as extra): {path}")
    return changed


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m penalty_env.envdocs", description="Write (or --check) the env pages in docs/envs/."
    )
    parser.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 listing stale, missing or extra pages"
    )
    parser.add_argument(
        "--out", type=Path, default=None, help="the pages' folder (default: docs/envs of this checkout)"
    )
    parser.add_argument(
        "--render",
        action="store_true",
        help="with --check: also render each id's picture again and compare its pixels (a few seconds "
        "once the kernels are compiled); without it --check only reads the committed pictures",
    )
    parser.add_argument(
        "--no-images",
        action="store_true",
        help="write the pages only, not their pictures (no env rendered)",
    )
    args = parser.parse_args(argv)
    out = args.out if args.out is not None else default_dir()
    if args.check:
        problems = check(out, frames=generate_images() if args.render else None)
        if problems:
            print("\n".join(problems))
            print(f"{len(problems)} file(s) out of date: run python -m penalty_env.envdocs")
            raise SystemExit(1)
        print(f"{out}: every page and picture up to date")
        return
    changed = write(out)
    if not args.no_images:
        changed += write_images(out, generate_images())
    print("\n".join(changed) if changed else f"{out}: every page and picture already up to date")
