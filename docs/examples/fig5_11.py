"""Fig. 5.11 from Python: peak-to-peak transmission error of the Gregory, Harris &
Munro rig against mesh frequency (27 runs in this process, about a second).
    python3 docs/examples/fig5_11.py [figure.png]"""
import sys
import matplotlib.pyplot as plt
import trainsim

runs = trainsim.sweep("inputs/sweep_ghm_mesh_frequency.nml")      # the deck's own &sweep groups
f, te = runs["mesh.mesh_frequency"], runs["mesh.p2p_mean"]
print(f"{len(runs)} runs, {int(sum(runs['run.settled'] == 1))} settled; "
      f"largest p2p TE {te.max():.3g} {runs.units['mesh.p2p_mean']} at {f[te.argmax()]:.0f} teeth/s")
plt.plot(f, te, "o-")
plt.xlabel("mesh frequency (teeth/s)"); plt.ylabel(f"p2p TE ({runs.units['mesh.p2p_mean']})")
plt.title("Gregory, Harris & Munro rig (Fig. 5.11)")
plt.savefig(sys.argv[1] if len(sys.argv) > 1 else "fig5_11.png", dpi=100)
