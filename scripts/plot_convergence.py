#!/usr/bin/env python3
"""Draws a surface convergence.csv (digilap-convergence on a surface) as a log-log PNG:
relative max error against h for each kind of normals (and, with --bias-correction, for L g and
L_c g), with the fitted slope and a slope-1 guide. Usage: scripts/plot_convergence.py convergence.csv out.png [title]"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

rows = list(csv.DictReader(open(sys.argv[1])))
title = sys.argv[3] if len(sys.argv) > 3 else "Laplace-Beltrami of x² on the unit sphere"
fig, ax = plt.subplots(figsize=(7, 5.2), dpi=100)
estimates = sorted({r.get("estimate") or "L" for r in rows}, key=lambda e: e != "L")  # L first
for estimate in estimates:
    for normals, marker in (("ii", "o"), ("exact", "s")):
        mine = [r for r in rows if r["normals"] == normals and (r.get("estimate") or "L") == estimate]
        if not mine:
            continue
        h = np.array([float(r["h"]) for r in mine])
        e = np.array([float(r["relative_max_error"]) for r in mine])
        slope = np.polyfit(np.log(h), np.log(e), 1)[0]
        name = f"{normals} normals" if estimate == "L" else f"{normals} normals, bias-corrected"
        ax.loglog(h, 100 * e, marker=marker, linestyle="-" if estimate == "L" else "--", label=f"{name} (slope {slope:.2f})")
h = np.array([float(r["h"]) for r in rows])
ax.loglog([h.min(), h.max()], [100 * float(rows[-1]["relative_max_error"]), 100 * float(rows[-1]["relative_max_error"]) * h.max() / h.min()],
          "k--", lw=0.8, label="slope 1")
ax.set_xlabel("grid step h")
ax.set_ylabel("relative max error (%)")
ax.set_title(title)
ax.grid(True, which="both", alpha=0.3)
ax.legend()
fig.tight_layout()
fig.savefig(sys.argv[2])
