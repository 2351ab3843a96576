"""Scaling of the physics core: ``python -m penalty_env.bench scale [--quick] [--max-n N] [--no-lammps]``.

Prints, writes (``docs/scale.csv``) and plots (``docs/scale.png``, log-log):
  (1) one settled world of N = 10^3 .. 10^6 frictionless balls in a bowl (the core benchmark's
      section (b) scene, ``packed_bowl`` scaled, settled with a drag: see ``settled_bed``):
      particle-substeps per second on 1 and 2 threads (``numba.set_num_threads``), and LAMMPS on
      the same state in the same run (``-pk omp 1`` and ``2``), interleaved in rounds;
  (2) the cost per particle-substep against N (flat within 1.5x from 10^3 to 10^6 is the target),
      the bytes per grain of the largest world (its arrays and neighbour list, and the growth of the
      process's resident memory), and whether it fits in memory;
  (3) batches: B worlds of n balls (each a small settled bed), stepped in one call of one World, on
      the path ``stepping="auto"`` picks and on the other paths that apply (target: 256 x 500
      within 1.5x of the 100,000-ball world's cost per particle-substep);
  (4) the 100,000-ball world of the core's own section (b) (slumped from its lattice for 6 s
      simulated, still sloshing): ours against LAMMPS, the "about 3x" figure, to tie (1) to it;
  (5) where the time of a settled world's step goes;
  (6) "history + rolling": the settled 100,000-ball bed (the largest N up to it) with friction, the
      tangential springs with history and rolling resistance, the balls spinning
      (``scale_spin``): ours on 1 and 2 threads against LAMMPS's ``pair_style granular`` on one
      (its granular style has no OPENMP variant): the per-core ratio (``--spin-only``: this alone).
The settled states are cached (``--cache-dir``, default ``~/.cache/penalty_env/scale``), keyed by N;
the first run settles them (the 10^6 one takes a few minutes).
"""

from __future__ import annotations

import argparse
import csv
from dataclasses import dataclass
from pathlib import Path

import numba

from ..physics.stepping.runner import thread_count
from .peer_lammps import Lammps, find_lammps

# the measurements, importable from here as before the split
from .scale_measure import (  # noqa: F401
    BLOCKS,
    CACHE_VERSION,
    DRAG,
    DRAG_EVERY,
    MASS,
    RADIUS,
    ROUNDS,
    SETTLE_S,
    SPACING,
    THREADS,
    WORK,
    Bed,
    Row,
    array_bytes,
    core_b_check,
    default_cache_dir,
    measure_batch,
    measure_memory,
    measure_single,
    settled_bed,
    time_blocks,
)
from .scale_profile import listed_world, phase_profile, profile_run  # noqa: F401
from .scale_spin import SPIN, measure_spin, spin_bed

SIZES = (1_000, 10_000, 100_000, 1_000_000)
BATCHES = ((64, 2000), (256, 500), (1024, 100), (256, 2000))
DOCS = Path(__file__).resolve().parents[2] / "docs"


def write_csv(rows: list[Row], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        out = csv.DictWriter(f, fieldnames=list(Row("", "", 0, 0, 0, "").csv()))
        out.writeheader()
        for r in rows:
            out.writerow(r.csv())


def plot(rows: list[Row], path: Path) -> None:
    """Log-log: particle-substeps/s against N (ours and LAMMPS, 1 and 2 threads), and ns per
    particle-substep against particles per call, with the batches."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.8))
    single = [r for r in rows if r.section == "single" and r.rates]
    for code, marker in (("penalty_env", "o"), ("lammps", "s")):
        for t, style in ((1, "--"), (2, "-")):
            pts = sorted((r.n_balls, r.best) for r in single if r.code == code and r.threads == t)
            if not pts:
                continue
            xs, ys = zip(*pts, strict=True)
            label = f"{code}, {t} thread{'s' if t > 1 else ''}"
            a.loglog(xs, ys, style, marker=marker, label=label)
            b.loglog(xs, [1e9 / y for y in ys], style, marker=marker, label=label)
    for r in rows:
        if r.section == "batch" and r.rates:
            mk = "^" if r.note == "auto" else "v"
            b.loglog([r.n_worlds * r.n_balls], [r.ns], mk, color="tab:purple" if r.note == "auto" else "tab:gray")
            b.annotate(
                f"{r.n_worlds}x{r.n_balls} {r.path}{' (auto)' if r.note == 'auto' else ''}",
                (r.n_worlds * r.n_balls, r.ns),
                fontsize=7,
                xytext=(4, 2),
                textcoords="offset points",
            )
    a.set_xlabel("balls in the world (N)")
    a.set_ylabel("particle-substeps per second")
    a.set_title("one settled world in a bowl")
    b.set_xlabel("particles per step call (N, or B x n for a batch)")
    b.set_ylabel("ns per particle-substep")
    b.set_title("cost per particle-substep (batches: triangles, 2 threads)")
    for ax in (a, b):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _parse_batch(s: str) -> tuple[int, int]:
    b, n = s.lower().split("x")
    return int(b), int(n)


def _parser() -> argparse.ArgumentParser:
    """The command line (its description: this module's docstring)."""
    ap = argparse.ArgumentParser(
        prog="python -m penalty_env.bench scale",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="N up to 10^4, small batches, short timings")
    ap.add_argument("--max-n", type=int, default=None, help="largest N of (1) (default 10^6; 10^4 with --quick)")
    ap.add_argument("--batches", nargs="*", default=None, help="batch shapes BxN (default 64x2000 256x500 ...)")
    ap.add_argument("--no-lammps", action="store_true", help="do not run LAMMPS")
    ap.add_argument("--no-core-b", action="store_true", help="skip (4), the core's own slumped 10^5 pile")
    ap.add_argument("--work", type=float, default=None, help="particle-substeps per timed measurement")
    ap.add_argument("--rounds", type=int, default=None, help="interleaved rounds (default 2; 1 with --quick)")
    ap.add_argument("--cache-dir", default=str(default_cache_dir()), help="where settled beds are kept")
    ap.add_argument("--out-dir", default=str(DOCS), help="where scale.csv and scale.png go")
    ap.add_argument(
        "--profile-run",
        nargs=2,
        type=int,
        metavar=("N", "STEPS"),
        help="only the profiled workload (for callgrind): the settled N-ball bed, 1 + STEPS steps",
    )
    ap.add_argument("--rebuild", action="store_true", help="with --profile-run: rebuild the list every step")
    ap.add_argument("--spin-only", action="store_true", help="only (6), the history + rolling bed, with LAMMPS")
    ap.add_argument("--no-spin", action="store_true", help="skip (6)")
    return ap


@dataclass
class _Settings:
    """What a run measures, from the command line and its --quick defaults."""

    quick: bool
    sizes: list[int]  # N of (1)
    batches: list[tuple[int, int]]  # (B, n) of (3)
    work: float
    rounds: int
    threads: tuple[int, ...]
    cache: Path | None
    out: Path


def _settings(args: argparse.Namespace) -> _Settings:
    quick = args.quick
    max_n = args.max_n if args.max_n is not None else (10_000 if quick else SIZES[-1])
    sizes = [n for n in SIZES if n <= max_n] or [max_n]
    batches = [_parse_batch(s) for s in args.batches] if args.batches is not None else None
    if batches is None:
        batches = [(16, 500), (64, 100)] if quick else list(BATCHES)
    work = args.work if args.work is not None else (2e6 if quick else WORK)
    rounds = args.rounds if args.rounds is not None else (1 if quick else ROUNDS)
    threads = tuple(t for t in THREADS if t <= thread_count())
    cache = Path(args.cache_dir) if args.cache_dir else None
    out = Path(args.out_dir)
    return _Settings(quick, sizes, batches, work, rounds, threads, cache, out)


def _peer(no_lammps: bool, cache: Path | None) -> Lammps | None:
    """Print the run's header and find LAMMPS (None: skipped or not there, said why)."""
    peer: Lammps | None = None
    print(
        f"penalty_env scale benchmark: symplectic Euler, {thread_count()} threads, "
        f"numba {numba.__version__}; settled beds from {cache}"
    )
    if not no_lammps:
        found = find_lammps()
        if isinstance(found, str):
            print(f"    peer: {found}")
        else:
            peer = found
            print(f"    peer: LAMMPS {found.version} (gran/hooke, wall/gran/region, nve; OPENMP, -pk omp T)")
    return peer


def _single_section(s: _Settings, peer: Lammps | None, rows: list[Row]) -> dict[int, Bed]:
    """(1): each N's settled world, ours against LAMMPS; appends to ``rows`` (the CSV rewritten
    after each N) and returns the beds."""
    print(
        f"(1) one settled world in a bowl: {s.rounds} interleaved round(s) of [ours on {s.threads} threads, "
        f"LAMMPS on each], {BLOCKS} blocks of ~{s.work / BLOCKS:.2g} particle-substeps each"
    )
    beds = {}
    for n in s.sizes:
        bed = beds[n] = settled_bed(n, s.cache, verbose=True)
        got = measure_single(bed, s.threads, s.work, BLOCKS, s.rounds, peer)
        rows += got
        ours = {r.threads: r for r in got if r.code == "penalty_env"}
        lmp = {r.threads: r for r in got if r.code == "lammps"}
        for t, r in ours.items():
            line = (
                f"    {n:>9,} balls, {t} thr: {r.best / 1e6:7.2f} M/s (median {r.median / 1e6:6.2f}), "
                f"{r.ns:6.1f} ns/particle-step, list every {r.steps_per_build:6.1f} steps, {r.listed_per_ball:4.1f} listed/ball"
            )
            if t in lmp and lmp[t].rates:
                line += f" | LAMMPS {lmp[t].best / 1e6:6.2f} M/s, ours {r.best / lmp[t].best:5.2f}x"
            elif t in lmp:
                line += f" | LAMMPS {lmp[t].note}"
            print(line, flush=True)
        write_csv(rows, s.out / "scale.csv")
    return beds


def _flatness_section(rows: list[Row], threads: tuple[int, ...], largest: Bed) -> None:
    """(2): the cost per particle-substep against N, and the bytes per grain of the largest world
    (appended to ``rows``)."""
    print("(2) cost per particle-substep against N (best block; target: flat within 1.5x)")
    for t in threads:
        ns = {r.n_balls: r.ns for r in rows if r.section == "single" and r.code == "penalty_env" and r.threads == t}
        lo, hi = min(ns.values()), max(ns.values())
        print(
            f"    {t} thread{'s' if t > 1 else ' '}: "
            + ", ".join(f"{n:,}: {v:.1f} ns" for n, v in sorted(ns.items()))
            + f"; largest / smallest N {ns[max(ns)] / ns[min(ns)]:.2f}x, max / min {hi / lo:.2f}x "
            f"({'flat' if hi / lo <= 1.5 else 'NOT flat'} within 1.5x)"
        )
    mem = measure_memory(largest)
    print(
        f"    memory at {mem['n']:,} balls: arrays {mem['arrays_per_grain']:.0f} B/grain (neighbour list "
        f"{mem['list_per_grain']:.0f} of it, {mem['capacity']} slots per ball); resident memory grew "
        f"{mem['rss_per_grain']:.0f} B/grain ({mem['rss_make_per_grain']:.0f} at World(), the rest at the first "
        f"step); process RSS {mem['rss_total'] / 2**30:.2f} GiB, {mem['available'] / 2**30:.1f} GiB still available"
    )
    mrow = Row("memory", "penalty_env", 1, mem["n"], numba.get_num_threads(), "neighbour_list")
    mrow.note = (
        f"arrays_B_per_grain={mem['arrays_per_grain']:.0f};list_B_per_grain={mem['list_per_grain']:.0f};"
        f"rss_growth_B_per_grain={mem['rss_per_grain']:.0f};rss_GiB={mem['rss_total'] / 2**30:.2f}"
    )
    rows.append(mrow)


def _batch_section(s: _Settings, rows: list[Row]) -> None:
    """(3): each batch shape, on every path that applies, against the 100,000-ball world of (1);
    appends to ``rows`` (the CSV rewritten after each shape)."""
    print(
        f"(3) batches of settled beds, one World, {numba.get_num_threads()} threads: every path that applies "
        "(auto's pick marked)"
    )
    ref = {r.threads: r for r in rows if r.section == "single" and r.code == "penalty_env" and r.n_balls == 100_000}
    ref2 = ref.get(max(s.threads))
    for worlds, n in s.batches:
        bed = settled_bed(n, s.cache)
        try:
            got = measure_batch(worlds, n, bed, s.work, BLOCKS, s.rounds)
        except MemoryError as exc:
            print(f"    {worlds} x {n}: out of memory ({exc})")
            continue
        rows += got
        for r in got:
            vs = f", {r.ns / ref2.ns:4.2f}x the 100,000-ball world's" if ref2 is not None else ""
            print(
                f"    {worlds:>5} x {n:>5}: {r.path:>14}{' (auto)' if r.note == 'auto' else '       '} "
                f"{r.best / 1e6:7.2f} M/s (median {r.median / 1e6:6.2f}), {r.ns:6.1f} ns/particle-step{vs}",
                flush=True,
            )
        write_csv(rows, s.out / "scale.csv")
    if ref2 is not None:
        print(
            "    target: 256 x 500 within 1.5x of the 100,000-ball world's ns/particle-step (best path and auto above)"
        )


def _core_b_section(peer: Lammps | None, threads: tuple[int, ...], rows: list[Row]) -> None:
    """(4): the core's own (b) pile against LAMMPS; appends to ``rows``."""
    print("(4) the core's (b) pile, 100,000 balls slumped from its lattice (6 s simulated), with LAMMPS")
    got = core_b_check(peer, threads)
    rows += got
    ours = {r.threads: r for r in got if r.code == "penalty_env"}
    for r in got:
        line = f"    {r.code:>11}, {r.threads} thr: {r.best / 1e6:7.2f} M/s (median {r.median / 1e6:6.2f})"
        if r.code == "lammps" and r.rates and r.threads in ours:
            line += f": ours {ours[r.threads].best / r.best:5.2f}x"
        print(line + (f" {r.note}" if r.note else ""))


def _profile_section(s: _Settings, rows: list[Row]) -> None:
    """(5): where the time of the largest settled world up to 100,000 balls goes; appends to ``rows``."""
    prof_n = max(n for n in s.sizes if n <= 100_000)
    prof = phase_profile(settled_bed(prof_n, s.cache), 20 if not s.quick else 5, 3)
    step, force, build = prof["step_s"], prof["force_s"], prof["build_s"]
    print(
        f"(5) where the time goes, the settled {prof_n:,}-ball world on 1 thread (best of 3, alternating): step "
        f"{1e9 * step / prof_n:.1f} ns/particle, force pass alone {100 * force / step:.0f}% of it (pairs, "
        f"{prof['listed_per_ball']:.2f} listed per ball, and the terrain of the {100 * prof['near_terrain']:.1f}% "
        f"of balls near it), advance and overheads {100 * (1 - force / step):.0f}%; one list build costs "
        f"{build / step:.1f} steps"
    )
    prow = Row("profile", "penalty_env", 1, prof_n, 1, "neighbour_list", [prof_n / step])
    prow.listed_per_ball = prof["listed_per_ball"]
    prow.note = (
        f"force_share={force / step:.3f};build_in_steps={build / step:.2f};near_terrain={prof['near_terrain']:.4f}"
    )
    rows.append(prow)


def _spin_section(s: _Settings, peer: Lammps | None, rows: list[Row]) -> None:
    """(6): the settled bed with history and rolling resistance, ours against LAMMPS; appends to
    ``rows``."""
    n = max(m for m in s.sizes if m <= 100_000)
    print(
        f"(6) history + rolling: the settled {n:,}-ball bed with mu = {SPIN['mu']:g}, the tangential springs with "
        f"history, rolling resistance mu_r = {SPIN['mu_r']:g}, spinning; {s.rounds} interleaved round(s) of [ours "
        f"on {s.threads} threads, LAMMPS pair granular on 1]"
    )
    bed = spin_bed(n, s.cache, verbose=True)
    got = measure_spin(bed, s.threads, s.work, BLOCKS, s.rounds, peer)
    rows += got
    lmp = [r for r in got if r.code == "lammps" and r.rates]
    for r in got:
        line = f"    {r.code:>11}, {r.threads} thr: {r.best / 1e6:7.3f} M/s (median {r.median / 1e6:6.3f}), {r.ns:6.1f} ns/particle-step"
        if r.code == "penalty_env":
            line += f", list every {r.steps_per_build:6.1f} steps, {r.note.split(';')[-1]}"
            if lmp:
                line += f" | ours / LAMMPS 1 thread: best {r.best / lmp[0].best:5.2f}x, median {r.median / lmp[0].median:5.2f}x"
        elif r.note.startswith("failed"):
            line += f" {r.note}"
        print(line, flush=True)


def main(argv: list[str] | None = None) -> None:
    args = _parser().parse_args(argv)
    if args.profile_run:
        profile_run(args.profile_run[0], args.profile_run[1], args.rebuild, Path(args.cache_dir))
        return
    s = _settings(args)
    peer = _peer(args.no_lammps, s.cache)
    rows: list[Row] = []
    if args.spin_only:
        _spin_section(s, peer, rows)
        write_csv(rows, s.out / "scale_spin.csv")
        print(f"wrote {s.out / 'scale_spin.csv'}")
        return
    beds = _single_section(s, peer, rows)
    _flatness_section(rows, s.threads, beds[s.sizes[-1]])
    del beds
    _batch_section(s, rows)
    if not args.no_core_b and not s.quick:
        _core_b_section(peer, s.threads, rows)
    _profile_section(s, rows)
    if not args.no_spin:
        _spin_section(s, peer, rows)
    write_csv(rows, s.out / "scale.csv")
    plot(rows, s.out / "scale.png")
    print(f"wrote {s.out / 'scale.csv'} and {s.out / 'scale.png'}")


if __name__ == "__main__":
    main()
