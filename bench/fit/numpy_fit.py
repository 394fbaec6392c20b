#!/usr/bin/env python3
"""The numpy reference pipeline bench_fit compares `standcal fit` with (issue 17).

What a bench engineer would write in an afternoon: parse the CSV, average each position,
and fit J = b + M u by weighted least squares (12 unknowns, the full-vector model linearised;
u from the commanded angles as docs/model.md defines it, mount x). Prints b and the diagonal
of M so that a broken pipeline shows; bench_fit times it."""
import sys

import numpy as np


def main(path: str) -> None:
    header_lines = 0
    g = 9.80665
    with open(path, encoding="utf-8") as f:
        for line in f:
            if not line.startswith("#"):
                break
            header_lines += 1
            if line.startswith("# g_local_mps2:"):
                g = float(line.split(":", 1)[1])
    # t_s, pos, alpha1_cmd_deg, alpha2_cmd_deg, fx, fy, fz (the recording's column order)
    data = np.loadtxt(path, delimiter=",", skiprows=header_lines + 1, usecols=(0, 1, 2, 3, 6, 7, 8))
    pos = data[:, 1].astype(np.int64)
    starts = np.flatnonzero(np.r_[True, pos[1:] != pos[:-1]])
    counts = np.diff(np.r_[starts, len(pos)])
    f = data[:, 4:7] / g
    means = np.add.reduceat(f, starts, axis=0) / counts[:, None]
    var = np.add.reduceat(f**2, starts, axis=0) / counts[:, None] - means**2
    se = np.sqrt(np.maximum(var, 1e-18) / counts[:, None])
    a1 = np.radians(data[starts, 2])
    a2 = np.radians(data[starts, 3])
    u = np.column_stack([np.sin(a1), np.cos(a1) * np.cos(a2), np.cos(a1) * np.sin(a2)])
    solution = []
    for axis in range(3):  # one row of M and one bias per axis
        A = np.column_stack([np.ones(len(u)), u]) / se[:, axis : axis + 1]
        y = means[:, axis] / se[:, axis]
        solution.append(np.linalg.lstsq(A, y, rcond=None)[0])
    print("bias_g", [s[0] for s in solution], "diag_M", [solution[k][k + 1] for k in range(3)])


if __name__ == "__main__":
    main(sys.argv[1])
