"""The table of results/mjx/README.md#the-training-physics, from the agreement log.

    python investigations/mjx_agreement_table.py [results/mjx/cpu_agreement_training_physics.log]

The log holds `investigations/mjx_agreement.py`'s output for each physics and gait, each run
under a line `== <physics name> <gait> <flags>` (the JSON line per seed that the script
prints); this prints, per physics and gait, the mean distance of the MJX and CPU trials,
the largest differences of distance and lateral drift, and the MJX falls.
"""

import json
import sys

import numpy as np


def read(path: str) -> dict:
    """{(physics, gait): [rows]} in the log's order."""
    runs, key = {}, None
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("== "):
                name, gait = line.split()[1:3]
                key = (name, gait)
                runs[key] = []
            elif line.startswith("{"):
                runs[key].append(json.loads(line))
    return runs


def row(trials: list) -> str:
    """One gait's cell: MJX mean (CPU mean), max |Δ distance|, max |Δ lateral|, falls."""
    d = np.array([t["mjx_f32"]["distance_m"] - t["cpu"]["distance_m"] for t in trials])
    lat = np.array([t["mjx_f32"]["lateral_m"] - t["cpu"]["lateral_m"] for t in trials])
    mean = np.mean([t["mjx_f32"]["distance_m"] for t in trials])
    falls = sum(t["mjx_f32"]["fall_step"] is not None for t in trials)
    return f"{mean:.3f} m, {abs(d).max():.2e} m, {abs(lat).max():.2e} m, {falls}/{len(trials)}"


def main(path: str) -> None:
    runs = read(path)
    names = list(dict.fromkeys(name for name, _ in runs))
    gaits = list(dict.fromkeys(gait for _, gait in runs))
    print("| physics | " + " | ".join(gaits) + " |")
    print("|---" * (len(gaits) + 1) + "|")
    for name in names:
        cells = [row(runs[(name, g)]) if runs.get((name, g)) else "" for g in gaits]
        print(f"| {name} | " + " | ".join(cells) + " |")
    cpu = [np.mean([t["cpu"]["distance_m"] for t in runs[(names[0], g)]]) for g in gaits]
    print("CPU means: " + ", ".join(f"{g} {m:.3f} m" for g, m in zip(gaits, cpu)))
    for g in gaits:
        trials = runs[(names[0], g)]
        d = [abs(t["cpu_perturbed"]["distance_m"] - t["cpu"]["distance_m"]) for t in trials]
        lat = [abs(t["cpu_perturbed"]["lateral_m"] - t["cpu"]["lateral_m"]) for t in trials]
        print(f"CPU from a start moved by 1e-9 rad, {g}: {max(d):.2e} m, {max(lat):.2e} m")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/mjx/cpu_agreement_training_physics.log")
