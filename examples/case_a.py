"""The paper's case (a) with the Python package: exciter at 2l/3, 10 V,
2 % per pseudo period; the force envelope on top, the tip displacement
envelope below, the full-order reference and the single-nonlinear-mode model
(`nlmode`) against Omega/omega0 (the figure `host run` draws as sweep.svg).

    python examples/case_a.py [OUT.png]
"""
import sys

import matplotlib.pyplot as plt

import nlmode

out = sys.argv[1] if len(sys.argv) > 1 else "case_a.png"
r = nlmode.run(methods=["reference", "nlmode"])  # the embedded default scenario
omega0 = r.summary["omega0_rad_s"]
fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
for method, style in [("reference", dict(color="0.5", lw=2.5)), ("nlmode", dict(color="C3", lw=1.2, ls="--"))]:
    env = r.envelope(method)
    eta = env["omega_rad_s"] / omega0
    top.plot(eta, env["force_amplitude_N"], label=method, **style)
    bottom.plot(eta, 1e3 * env["tip_amplitude_m"], label=method, **style)
top.set_ylabel("|F| [N]")
bottom.set_ylabel("|q_tip| [mm]")
bottom.set_xlabel("Omega / omega0 [-]")
top.set_title(r.summary["title"])
top.legend()
for ax in (top, bottom):
    ax.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(out, dpi=120)
s = r.summary["methods"]
print(
    f"wrote {out}: peak tip {1e3 * s['nlmode']['peak_tip_amplitude_m']:.3f} mm (nlmode), "
    f"{1e3 * s['reference']['peak_tip_amplitude_m']:.3f} mm (reference)"
)
