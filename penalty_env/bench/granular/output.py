"""What the cases (``case_packing``, ``case_repose``, ``case_beverloo``, ``case_lammps``,
``case_lammps_repose``) share to write their results: the figure backend (matplotlib without a
display) and the CSV writer."""

from __future__ import annotations

# ----------------------------------------------------------------------------------------------
# The cases: each writes docs/granular_<case>.csv and .png and returns its summary
# ----------------------------------------------------------------------------------------------


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _write_csv(path: str, header: list[str], rows) -> None:
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for row in rows:
            f.write(",".join(f"{v:.6g}" if isinstance(v, float) else str(v) for v in row) + "\n")
