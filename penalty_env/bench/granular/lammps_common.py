"""What both LAMMPS cross-checks share: the input's lines for grains among frozen spheres (the
silo's rim, the pile's base), finding LAMMPS and running an input in a folder of its own."""

from __future__ import annotations

import os


def _frozen_type_2(group: str, law, kd: float, m: float) -> str:
    """The LAMMPS input's lines for grains (type 1) among frozen spheres (type 2, the group ``group``):
    ``law(gamma_n)`` between grains with gamma_n = kd / (m / 2) (m_eff = m / 2: our kd), and
    against the frozen spheres with kd / m (the granular pair styles take m_eff = the mobile grain's
    mass there: our kd again); no pairs among the frozen spheres."""
    return f"""group grains type 1
group {group} type 2
pair_style granular
pair_coeff 1 1 {law(kd / (m / 2.0))}
pair_coeff 1 2 {law(kd / m)}
pair_coeff 2 2 {law(kd / m)}
neigh_modify exclude type 2 2
fix freeze {group} freeze
"""


def _run_lammps(lmp, tmp: str, script: str) -> None:
    import subprocess

    with open(os.path.join(tmp, "in.silo"), "w") as f:
        f.write(script)
    cmd = [lmp.lmp, "-in", "in.silo", "-log", "none", "-echo", "none", "-sf", "omp", "-pk", "omp", "1"]
    res = subprocess.run(cmd, cwd=tmp, env=dict(lmp.env, OMP_NUM_THREADS="1"), capture_output=True, text=True)
    if res.returncode != 0 or "Lost atoms" in res.stdout + res.stderr:
        raise RuntimeError(f"LAMMPS failed: {(res.stdout + res.stderr)[-2000:]}")


def _lammps(lmp):
    from ..peer_lammps import Lammps, find_lammps

    lmp = lmp or find_lammps()
    if not isinstance(lmp, Lammps):
        raise RuntimeError(lmp)
    return lmp
